//! The built-in demonstration of what works so far, on real tactile data.

use anyhow::{Context, Result, bail};
use encoders::dataset::{Dataset, SampleData, Split};
use encoders::formats::aedat4::{self, EncoderOptions};
use encoders::formats::{self, AtomicFile, EventSink, OpenOptions};
use encoders::heatmap::{HeatmapConfig, HeatmapEncoder};
use encoders::sigma_delta::{self, SigmaDeltaConfig};
use encoders::stats::StreamStats;
use encoders::{Event, Polarity};
use sim::{Board, BoardGeometry, BoardKind, ScanConfig};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Analog dataset folder (raw.csv, split.csv) [default: the repository's data/icub_braille/raw1350].
    #[arg(long)]
    data: Option<PathBuf>,
    /// Sampling period of the analog data, in microseconds (iCub: 40 Hz).
    #[arg(long, default_value_t = 25_000)]
    period_us: i64,
    /// Sigma-delta threshold, in taxel units.
    #[arg(long, default_value_t = 2.0)]
    threshold: f32,
    /// Text to spell from recorded test-split letters (A-Z and spaces).
    #[arg(long, default_value = "HELLO WORLD")]
    text: String,
    /// Folder for the demo's event files [default: a folder in the system's temporary directory].
    #[arg(long)]
    out: Option<PathBuf>,
}

/// A file of the repository: from the working directory, else from where the binary was built.
fn repo_path(rel: &str) -> PathBuf {
    let local = PathBuf::from(rel);
    if local.exists() { local } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(rel) }
}

pub fn run(args: Args) -> Result<()> {
    let data = args.data.clone().unwrap_or_else(|| repo_path("data/icub_braille/raw1350"));
    println!("braille demo: what works so far, on real data\n");
    let t = Instant::now();
    let ds = Dataset::load(&data, args.period_us).with_context(|| format!("loading the dataset {}", data.display()))?;
    println!(
        "1. Loaded {} ({} samples, {} classes, {} taxels at {:.0} Hz) in {:.2} s: iCub fingertip Braille\n   recordings, Müller-Cleve et al. 2022 (real sensor data).",
        data.display(),
        ds.samples.len(),
        ds.classes.len(),
        ds.channels,
        1e6 / args.period_us as f64,
        t.elapsed().as_secs_f64()
    );

    // Sigma-delta encoding of every sample: pressure = 255 - reading (255 = no contact).
    let cfg = SigmaDeltaConfig { threshold: args.threshold, interpolate: false };
    let t = Instant::now();
    let mut encoded: Vec<(usize, Split, Vec<Event>)> = Vec::with_capacity(ds.samples.len());
    for s in &ds.samples {
        let SampleData::Analog { frames } = &s.data else {
            bail!("{} holds event data; the demo encodes analog data", data.display())
        };
        let pressure: Vec<f32> = frames.iter().map(|v| 255.0 - v).collect();
        encoded.push((s.label, s.split, sigma_delta::encode(&cfg, &pressure, ds.channels, args.period_us)?));
    }
    let total: usize = encoded.iter().map(|e| e.2.len()).sum();
    println!(
        "2. Sigma-delta encoded (threshold {}) into {} events, {:.1} per sample, in {:.1} ms.",
        args.threshold,
        total,
        total as f64 / encoded.len() as f64,
        t.elapsed().as_secs_f64() * 1e3
    );

    // A stream that spells the text from test-split recordings, letter after letter.
    let mut stream: Vec<Event> = Vec::new();
    let mut spelled = String::new();
    let mut offset_us = 0i64;
    let sample_us = 2_000_000i64;
    for ch in args.text.to_uppercase().chars() {
        let name = if ch == ' ' { "Space".to_string() } else { ch.to_string() };
        let Some(label) = ds.classes.iter().position(|c| *c == name) else {
            bail!("no class {name:?} in {}; classes: {}", data.display(), ds.classes.join(" "))
        };
        let (_, _, ev) = encoded.iter().find(|(l, s, _)| *l == label && *s == Split::Test).context("no test sample")?;
        stream.extend(ev.iter().map(|e| Event { t_us: e.t_us + offset_us, ..*e }));
        spelled.push(ch);
        offset_us += sample_us;
    }
    let out = args.out.clone().unwrap_or_else(|| std::env::temp_dir().join("braille-demo"));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join("icub_text.aedat4");
    let resolution = ds.resolution();
    let file = AtomicFile::create(&path, true)?;
    let mut sink = aedat4::Encoder::new(
        file,
        Some(resolution),
        EncoderOptions { source: "iCub fingertip (sigma-delta)".into(), ..Default::default() },
    )?;
    EventSink::write(&mut sink, &stream)?;
    Box::new(sink).finish()?;
    let (info, back) = formats::read_all(&path, &OpenOptions::default())?;
    if back != stream {
        bail!("{} did not read back the events written", path.display());
    }
    let mut stats = StreamStats::default();
    stats.add(&back);
    println!(
        "3. Wrote {:?} as one stream of {} events ({:.1} s, ON/OFF {:.2}) to {}\n   (AEDAT 4.0, LZ4, {} taxels as a {} sensor) and read it back identical.",
        spelled,
        stats.events,
        stats.duration_s(),
        stats.on_off_ratio().unwrap_or(f64::NAN),
        path.display(),
        ds.channels,
        info.resolution.map_or("?".into(), |r| r.to_string()),
    );

    // Heat map in 100 ms bins: one text row per taxel, one column per bin.
    let bin_us = 250_000;
    let enc = HeatmapEncoder::new(HeatmapConfig { bin_us, pool: 1, sensor: resolution, mask_cols: None })?;
    let bins = (offset_us / bin_us) as usize;
    let map = enc.encode(&back, 0, bins);
    println!(
        "4. Heat map (eq. 4 of the paper), {} ms bins, ON + OFF events per taxel (. 1-2, o 3-5, O 6+):",
        bin_us / 1000
    );
    let per_letter = (sample_us / bin_us) as usize;
    let header: String = spelled.chars().map(|c| format!("{c:<per_letter$}")).collect();
    println!("           {header}");
    for taxel in 0..ds.channels {
        let row: String = (0..bins)
            .map(|b| match map.get(b, 0, 0, taxel) + map.get(b, 1, 0, taxel) {
                0.0 => ' ',
                n if n <= 2.0 => '.',
                n if n <= 5.0 => 'o',
                _ => 'O',
            })
            .collect();
        println!("  taxel {taxel:>2} {row}");
    }
    read_letters(&back, resolution, &spelled, sample_us, &ds.classes, args.threshold)?;
    simulated_scan(&out)?;
    println!(
        "\nNot built yet: reading words from a continuous scan (the segmentation network, `braille read`).\nThe character classifiers on simulated scans: `braille eval chars`, `bash scripts/table1.sh`; see the README."
    );
    Ok(())
}

/// The shipped iCub SNN reads the stream back, letter by letter (each letter's 2 s slice of the
/// stream), on the event-driven engine.
fn read_letters(
    stream: &[Event],
    resolution: encoders::Resolution,
    truth: &str,
    sample_us: i64,
    classes: &[String],
    threshold: f32,
) -> Result<()> {
    let path = repo_path("models/snn-raw1350.safetensors");
    let model = snn::model_file::SnnModel::load(&path)?;
    let enc: learn::data::TactileEncoding = serde_json::from_value(model.preprocess.clone())
        .with_context(|| format!("{}: header `preprocess` is not a tactile encoding", path.display()))?;
    if enc.sigma_delta.as_ref().is_some_and(|sd| sd.threshold != threshold) || model.classes != classes {
        println!("4b. (skipped: the shipped SNN was trained with another encoding or classes than this demo's)");
        return Ok(());
    }
    let encoder = enc.encoder(resolution)?;
    let engine = snn::engine::Engine::new(&model.network, model.config.dt_us, snn::engine::Mode::Stepped)?;
    let mut state = engine.state(0);
    let t = Instant::now();
    let mut read = String::new();
    let mut synops = 0u64;
    for (i, _) in truth.chars().enumerate() {
        let (a, b) = (i as i64 * sample_us, (i as i64 + 1) * sample_us);
        let lo = stream.partition_point(|e| e.t_us < a);
        let hi = stream.partition_point(|e| e.t_us < b);
        // The stream encodes pressure (255 - reading); the model was trained on the readings as
        // recorded, whose sigma-delta events are the same with ON and OFF swapped.
        let letter: Vec<Event> = stream[lo..hi]
            .iter()
            .map(|e| Event { t_us: e.t_us - a, polarity: Polarity::from_on(!e.polarity.is_on()), ..*e })
            .collect();
        engine.reset(&mut state, 0);
        engine.run_train(&mut state, &encoder.encode(&letter, 0, enc.steps))?;
        synops += state.stats.synops;
        let best = crate::eval::argmax(state.output_v_max().iter().copied());
        read.push(match classes.get(best).map(String::as_str) {
            Some("Space") => ' ',
            Some(c) => c.chars().next().unwrap_or('?'),
            None => '?',
        });
    }
    let right = read.chars().zip(truth.chars()).filter(|(a, b)| a == b).count();
    println!(
        "4b. The shipped SNN ({}) read the stream back letter by letter on the event-driven\n    engine: {:?} -> {:?}, {}/{} letters right, in {:.1} ms for {:.0} s of stream ({} synaptic\n    operations). Real recordings; each letter's 2 s slice is given.",
        path.display(),
        truth,
        read,
        right,
        truth.chars().count(),
        t.elapsed().as_secs_f64() * 1e3,
        (truth.chars().count() as i64 * sample_us) as f64 / 1e6,
        synops
    );
    Ok(())
}

/// A simulated Evetac scan of the paper's EV board (simulated data, not a recording).
fn simulated_scan(out: &Path) -> Result<()> {
    let kind = BoardKind::Ev;
    let board = Board::new(kind.clone(), BoardGeometry::default(), Board::default_seed(&kind))?;
    let sensor = crate::simulate::sensor(encoders::Resolution::DVXPLORER, 1)?;
    let scan = ScanConfig { speed_mm_s: 16.0, depth_mm: 1.0, row: 0, seed: 1, ..ScanConfig::default() };
    let t = Instant::now();
    let s = sim::simulate(&board, &sensor, &scan)?;
    let wall = t.elapsed().as_secs_f64();
    let path = out.join("ev_row0_16mm_s.aedat4");
    crate::simulate::write_events(&path, &s.events, sensor.camera.resolution, true)?;
    crate::simulate::write_json(&crate::simulate::truth_path(&path), &s.truth, true)?;
    let mut stats = StreamStats::default();
    stats.add(&s.events);
    println!(
        "5. SIMULATED scan (virtual Evetac, not a recording): EV board row 0 {:?} at 16 mm/s, 1.0 mm deep:\n   {} events over {:.1} s of sensor time (ON/OFF {:.2}), simulated in {:.2} s; written with its\n   ground truth to {}.",
        s.truth.row_text,
        stats.events,
        s.truth.timeline.end_s,
        stats.on_off_ratio().unwrap_or(f64::NAN),
        wall,
        path.display()
    );
    // Where the activity is: events per 250 ms at the sensor's centre band, with the letters.
    let bin_us = 250_000i64;
    let bins = (s.truth.timeline.end_s * 1e6 / bin_us as f64).ceil() as usize;
    let mut counts = vec![0usize; bins];
    let cx = sensor.camera.resolution.width / 2;
    for e in s.events.iter().filter(|e| e.x.abs_diff(cx) < 16) {
        counts[(e.t_us / bin_us) as usize] += 1;
    }
    let mut letters = vec![' '; bins];
    for c in &s.truth.characters {
        if let Some(t) = c.t_cell_center_s {
            letters[((t * 1e6) as i64 / bin_us) as usize] = c.letter;
        }
    }
    let max = counts.iter().copied().max().unwrap_or(1).max(1);
    let bar: String = counts.iter().map(|&n| [' ', '.', ':', 'o', 'O'][(4 * n).div_ceil(max).min(4)]).collect();
    println!("   events at the sensor's centre, 250 ms per character (truth below):");
    println!("   |{bar}|\n   |{}|", letters.iter().collect::<String>());
    Ok(())
}
