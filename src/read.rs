//! `braille read`: the words in an event stream (a file, or standard input as it arrives), read
//! by the segmentation network, a character classifier (the ResNet or the SNN) and the temporal
//! filter, then spell-corrected.

use crate::chars::CharModel;
use crate::train::ArchArg;
use anyhow::{Context, Result, bail};
use encoders::formats::{self, OpenOptions};
use encoders::{Event, Resolution};
use pipeline::classify::{SnnRunner, WindowModel};
use pipeline::reader::{ReadOutput, ReaderConfig, ReaderStats, Spell, Speller, StreamReader};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SpellArg {
    None,
    Textblob,
    Lexicon,
}

impl SpellArg {
    pub fn spell(self) -> Spell {
        match self {
            SpellArg::None => Spell::None,
            SpellArg::Textblob => Spell::Textblob,
            SpellArg::Lexicon => Spell::Lexicon,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SnnRunnerArg {
    Sliding,
    Engine,
}

impl SnnRunnerArg {
    pub fn runner(self) -> SnnRunner {
        match self {
            SnnRunnerArg::Sliding => SnnRunner::Sliding,
            SnnRunnerArg::Engine => SnnRunner::Engine,
        }
    }
}

/// A model file as a window reader.
pub fn load_window_model(arch: ArchArg, path: &Path, runner: SnnRunner) -> Result<WindowModel> {
    Ok(match CharModel::load(arch, path)? {
        CharModel::Resnet(m) => WindowModel::resnet(m.model, m.input, m.classes),
        CharModel::Snn { model, input } => {
            WindowModel::snn(model, input, runner).with_context(|| format!("{}", path.display()))?
        }
    })
}

/// The shipped models of each architecture: (segmentation network, character classifier).
pub fn default_models(arch: ArchArg) -> (PathBuf, PathBuf) {
    let (s, c) = match arch {
        ArchArg::Resnet => ("models/resnet-tiny-segment.safetensors", "models/resnet-lite-normaug-words.safetensors"),
        ArchArg::Snn => ("models/snn-segment.safetensors", "models/snn-words.safetensors"),
    };
    (crate::repo_path(s), crate::repo_path(c))
}

/// The two networks of one architecture, loaded and checked.
pub struct Readers {
    pub segmenter: WindowModel,
    pub classifier: WindowModel,
}

impl Readers {
    pub fn load(
        arch: ArchArg,
        segmenter: Option<&Path>,
        classifier: Option<&Path>,
        snn_runner: SnnRunner,
    ) -> Result<Readers> {
        let (ds, dc) = default_models(arch);
        let (sp, cp) = (segmenter.map_or(ds, Path::to_path_buf), classifier.map_or(dc, Path::to_path_buf));
        let seg = load_window_model(arch, &sp, snn_runner)?;
        let cls = load_window_model(arch, &cp, snn_runner)?;
        if seg.classes() != ["background", "character"] {
            bail!("{}: not a segmentation network (classes {:?})", sp.display(), seg.classes());
        }
        if cls.classes().len() != 26 {
            bail!("{}: not a 26-letter character classifier (classes {:?})", cp.display(), cls.classes());
        }
        if seg.input().labeler != cls.input().labeler {
            bail!("{} and {} window their input differently", sp.display(), cp.display());
        }
        Ok(Readers { segmenter: seg, classifier: cls })
    }

    pub fn config(&self, speed_mm_s: f64) -> ReaderConfig {
        ReaderConfig { labeler: self.classifier.input().labeler.clone(), ..ReaderConfig::new(speed_mm_s) }
    }

    /// Reads a whole stream of events in memory (simulated scans): the words and the counters.
    pub fn read(
        &mut self,
        events: &[Event],
        resolution: Resolution,
        speed_mm_s: f64,
        speller: &Speller,
    ) -> Result<(Vec<pipeline::reader::ReadWord>, ReaderStats)> {
        let cfg = self.config(speed_mm_s);
        Ok(pipeline::reader::read_all(events, cfg, resolution, &mut self.segmenter, &mut self.classifier, speller)?)
    }
}

#[derive(clap::Args)]
pub struct Args {
    /// Event file (.aedat4, .csv, .npy), or `-` for standard input (read as it arrives).
    file: PathBuf,
    #[arg(long, value_enum, default_value = "snn")]
    arch: ArchArg,
    #[arg(long, value_enum, default_value = "lexicon")]
    spell: SpellArg,
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
    snn_runner: SnnRunnerArg,
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
    arch: &'static str,
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
    let truth = crate::simulate::truth_path(&args.file);
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
    let mut readers =
        Readers::load(args.arch, args.segmenter.as_deref(), args.model.as_deref(), args.snn_runner.runner())?;
    let options = OpenOptions { resolution: args.resolution, stream_id: None };
    let mut source = if args.file.as_os_str() == "-" {
        formats::open_stdin(&options)?
    } else {
        formats::open(&args.file, &options)?
    };
    let resolution = args.resolution.or(source.info().resolution).unwrap_or(Resolution::DVXPLORER);
    let spell = args.spell.spell();
    let speller = Speller::new(spell);
    let cfg = readers.config(speed);
    let started = Instant::now();
    let mut reader = StreamReader::new(cfg, resolution, &mut readers.segmenter, &mut readers.classifier, &speller)?;
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
    drop(reader);
    let s = Summary {
        summary: true,
        data: path,
        arch: match args.arch {
            ArchArg::Resnet => "resnet",
            ArchArg::Snn => "snn",
        },
        spell,
        speed_mm_s: speed,
        text: text.join(" "),
        stream_s: first.map_or(0.0, |f| (last - f) as f64 / 1e6),
        read_s: started.elapsed().as_secs_f64(),
        stats,
        segmenter_ms: readers.segmenter.nanos as f64 / 1e6,
        classifier_ms: readers.classifier.nanos as f64 / 1e6,
        segmenter_synops: readers.segmenter.synops,
        classifier_synops: readers.classifier.synops,
        segmenter_us_p50: readers.segmenter.latency.quantile_ns(0.5).map(|n| n / 1e3),
        segmenter_us_p99: readers.segmenter.latency.quantile_ns(0.99).map(|n| n / 1e3),
        classifier_us_p50: readers.classifier.latency.quantile_ns(0.5).map(|n| n / 1e3),
        classifier_us_p99: readers.classifier.latency.quantile_ns(0.99).map(|n| n / 1e3),
        segmenter_latency: readers.segmenter.latency.clone(),
        classifier_latency: readers.classifier.latency.clone(),
        peak_rss_mb: crate::bench::peak_rss_mb(),
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
