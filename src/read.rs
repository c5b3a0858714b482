//! `braille read`: the words in an event stream (a file, or standard input as it arrives), read
//! by the segmentation network, a character classifier (the ResNet or the SNN) and the temporal
//! filter, then spell-corrected.

use anyhow::{Context, Result, bail};
use encoders::Resolution;
use encoders::formats::{self, OpenOptions};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{ReadOutput, ReaderStats, Spell, Speller};
use serde::Serialize;
use snn::model_file::Arch;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Event file (.aedat4, .csv, .npy), or `-` for standard input (read as it arrives).
    file: PathBuf,
    #[arg(long, value_enum, default_value = "snn")]
    arch: Arch,
    #[arg(long, value_enum, default_value = "lexicon")]
    spell: Spell,
    /// Scanning speed in mm/s [default: the speed in the file's ground truth, FILE.truth.json, as
    /// `braille simulate` writes it].
    #[arg(long)]
    speed: Option<f64>,
    /// Segmentation network [default: the architecture's shipped one].
    #[arg(long)]
    segmenter: Option<PathBuf>,
    /// Character classifier [default: the architecture's shipped one].
    #[arg(long)]
    model: Option<PathBuf>,
    /// How the SNN reads each frame's window: `sliding` shares the first layer's work between
    /// overlapping windows (the same output), `engine` runs each window on the event-driven engine.
    #[arg(long, value_enum, default_value = "sliding")]
    snn_runner: SnnRunner,
    /// The sensor's resolution, WIDTHxHEIGHT [default: what the file declares, else 640x480].
    #[arg(long)]
    resolution: Option<Resolution>,
    /// JSON Lines: one object per word as it completes, then a summary object.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Summary {
    summary: bool,
    data: String,
    arch: Arch,
    spell: Spell,
    speed_mm_s: f64,
    text: String,
    stream_s: f64,
    read_s: f64,
    #[serde(flatten)]
    stats: ReaderStats,
    /// Time and synaptic operations (SNN) of each network.
    segmenter_ms: f64,
    classifier_ms: f64,
    segmenter_synops: u64,
    classifier_synops: u64,
    /// Per call, in microseconds: the segmentation network on every frame, the classifier where
    /// a character is present.
    segmenter_us_p50: Option<f64>,
    segmenter_us_p99: Option<f64>,
    classifier_us_p50: Option<f64>,
    classifier_us_p99: Option<f64>,
    segmenter_latency: pipeline::classify::Histogram,
    classifier_latency: pipeline::classify::Histogram,
    peak_rss_mb: Option<f64>,
}

fn speed_of(args: &Args) -> Result<f64> {
    if let Some(s) = args.speed {
        return Ok(s);
    }
    let truth = crate::common::truth_path(&args.file);
    if args.file.as_os_str() != "-" && truth.exists() {
        let t: sim::ScanTruth = serde_json::from_reader(std::io::BufReader::new(
            std::fs::File::open(&truth).with_context(|| format!("opening {}", truth.display()))?,
        ))
        .with_context(|| format!("{}: not a scan's ground truth", truth.display()))?;
        return Ok(t.scan.speed_mm_s);
    }
    bail!("give the scanning speed with --speed (mm/s): {} has no ground truth beside it", args.file.display())
}

pub fn run(args: Args) -> Result<()> {
    let speed = speed_of(&args)?;
    let (ds, dc) = experiments::words::default_models(args.arch, &crate::common::repo_path("models"));
    let readers = ReaderModels::load(
        args.segmenter.as_deref().unwrap_or(&ds),
        args.model.as_deref().unwrap_or(&dc),
        args.snn_runner,
    )?;
    let options = OpenOptions { resolution: args.resolution, stream_id: None };
    let mut source = if args.file.as_os_str() == "-" {
        formats::open_stdin(&options)?
    } else {
        formats::open(&args.file, &options)?
    };
    let resolution = args.resolution.or(source.info().resolution).unwrap_or(Resolution::DVXPLORER);
    let spell = args.spell;
    let speller = Speller::new(spell);
    let started = Instant::now();
    let mut reader = readers.stream(speed, resolution, &speller)?;
    let (mut out, mut text) = (Vec::new(), Vec::<String>::new());
    let (mut first, mut last) = (None, 0i64);
    let stdout = std::io::stdout();
    let path = args.file.display().to_string();
    let emit = |out: &mut Vec<ReadOutput>, text: &mut Vec<String>| -> Result<()> {
        let mut lock = stdout.lock();
        for o in out.drain(..) {
            if let ReadOutput::Word(w) = o {
                if args.json {
                    serde_json::to_writer(&mut lock, &w)?;
                    writeln!(lock)?;
                } else {
                    let c = w.chars.first().map_or(0, |c| c.t_start_us);
                    writeln!(
                        lock,
                        "{:>9.3} s  {:<12} (read {}, {} letters)",
                        c as f64 / 1e6,
                        w.text,
                        w.raw,
                        w.chars.len()
                    )?;
                }
                lock.flush()?;
                // the running text is what the summary prints; on an endless stream only its last
                // thousand words are kept
                text.push(w.text);
                if text.len() > 1000 {
                    text.remove(0);
                }
            }
        }
        Ok(())
    };
    while let Some(chunk) = source.next_chunk().with_context(|| format!("reading {path}"))? {
        first.get_or_insert(chunk[0].t_us);
        last = chunk[chunk.len() - 1].t_us;
        reader.push_all(chunk, &mut out).with_context(|| path.clone())?;
        emit(&mut out, &mut text)?;
    }
    reader.finish(&mut out)?;
    emit(&mut out, &mut text)?;
    let stats = reader.stats.clone();
    let (seg, cls) = reader.into_states();
    let s = Summary {
        summary: true,
        data: path,
        arch: args.arch,
        spell,
        speed_mm_s: speed,
        text: text.join(" "),
        stream_s: first.map_or(0.0, |f| (last - f) as f64 / 1e6),
        read_s: started.elapsed().as_secs_f64(),
        stats,
        segmenter_ms: seg.stats.nanos as f64 / 1e6,
        classifier_ms: cls.stats.nanos as f64 / 1e6,
        segmenter_synops: seg.stats.synops,
        classifier_synops: cls.stats.synops,
        segmenter_us_p50: seg.stats.latency.quantile_ns(0.5).map(|n| n / 1e3),
        segmenter_us_p99: seg.stats.latency.quantile_ns(0.99).map(|n| n / 1e3),
        classifier_us_p50: cls.stats.latency.quantile_ns(0.5).map(|n| n / 1e3),
        classifier_us_p99: cls.stats.latency.quantile_ns(0.99).map(|n| n / 1e3),
        segmenter_latency: seg.stats.latency.clone(),
        classifier_latency: cls.stats.latency.clone(),
        peak_rss_mb: experiments::peak_rss_mb(),
    };
    if args.json {
        println!("{}", serde_json::to_string(&s)?);
    } else {
        println!(
            "read {:?} from {:.1} s of stream in {:.2} s ({} architecture, spelling {:?}, {} mm/s); {} frames, segmentation network on {} ({:.0} ms), classifier on {} ({:.0} ms)",
            s.text,
            s.stream_s,
            s.read_s,
            s.arch,
            s.spell,
            s.speed_mm_s,
            s.stats.frames,
            s.stats.segmenter_calls,
            s.segmenter_ms,
            s.stats.classifier_calls,
            s.classifier_ms
        );
    }
    Ok(())
}
