//! `braille demo`: both readers on SIMULATED scans of the EV board and of a contracted UEB
//! sentence, then the shipped SNN on real iCub recordings spelled into a stream, written as AEDAT
//! 4.0 and read back.

use anyhow::{Context, Result, bail};
use encoders::Event;
use encoders::dataset::Dataset;
use encoders::formats::aedat4::{self, EncoderOptions};
use encoders::formats::{self, AtomicFile, EventSink, OpenOptions};
use encoders::heatmap::{HeatmapConfig, HeatmapEncoder};
use encoders::stats::StreamStats;
use sim::BoardKind;
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

pub fn run(args: Args) -> Result<()> {
    let data = args.data.clone().unwrap_or_else(|| crate::common::repo_path("data/icub_braille/raw1350"));
    let out = args.out.clone().unwrap_or_else(|| std::env::temp_dir().join("braille-demo"));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    println!("braille demo\n");
    read_words(&out)?;
    read_ueb(&out)?;
    println!("Real tactile recordings (iCub fingertip, not Evetac): events, files, the SNN on the engine.\n");
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

    // A stream that spells the text from test-split recordings (sigma-delta encoded pressure,
    // 255 - reading), letter after letter.
    let t = Instant::now();
    let spelled = experiments::eval::tactile::spell_stream(&ds, &args.text, args.threshold, args.period_us)
        .with_context(|| data.display().to_string())?;
    println!(
        "2. Sigma-delta encoded (threshold {}) into {} events, {:.1} per sample, in {:.1} ms.",
        args.threshold,
        spelled.encoded_events,
        spelled.encoded_events as f64 / spelled.samples.max(1) as f64,
        t.elapsed().as_secs_f64() * 1e3
    );
    let (stream, sample_us) = (spelled.events, spelled.sample_us);
    let offset_us = sample_us * spelled.text.chars().count() as i64;
    let spelled = spelled.text;
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
    println!("\nMore: `braille report words`, `braille eval words`, `braille eval chars`; see the README.");
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
    let path = crate::common::shipped().icub("raw1350", pipeline::shipped::Variant::Trained);
    let model = pipeline::models::load_snn(&path)?;
    let enc = experiments::eval::tactile::encoding_of(&model, &path)?;
    if enc.sigma_delta.as_ref().is_some_and(|sd| sd.threshold != threshold) || model.classes != classes {
        println!("4b. (skipped: the shipped SNN was trained with another encoding or classes than this demo's)");
        return Ok(());
    }
    let t = Instant::now();
    let n = truth.chars().count();
    let (read, synops) = experiments::eval::tactile::read_letters(&model, &path, stream, resolution, n, sample_us)?;
    let right = read.chars().zip(truth.chars()).filter(|(a, b)| a == b).count();
    println!(
        "4b. The shipped SNN ({}) read the stream back letter by letter on the event-driven\n    engine: {:?} -> {:?}, {}/{} letters right, in {:.1} ms for {:.0} s of stream ({} synaptic\n    operations). Real recordings; each letter's 2 s slice is given.",
        path.display(),
        truth,
        read,
        right,
        n,
        t.elapsed().as_secs_f64() * 1e3,
        (n as i64 * sample_us) as f64 / 1e6,
        synops
    );
    Ok(())
}

/// The main job: both rows of the paper's EV board scanned at 16 mm/s by the virtual Evetac at the
/// `nominal` preset with a test sensor build (SIMULATED), each read from its raw events by both
/// architectures' models trained at `nominal`.
fn read_words(out: &Path) -> Result<()> {
    use pipeline::reader::{Spell, Speller};
    let kind = BoardKind::Ev;
    let world = corpus::world::World::test(sim::Realism::Nominal);
    let setup = world.setup();
    let board = world.board(&setup, &kind)?;
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, world.sensor_seed(0))?;
    let (speed, depth) = (16.0, 1.5);
    println!(
        "Reading Braille words from raw events (SIMULATED: virtual Evetac scans, not recordings).\nThe EV board at {speed} mm/s, {depth} mm deep, on the `nominal` simulator (gel dynamics, print\ntexture, drift, a sensor build no model was trained on). Each scan is read from its events\nalone: the speed is estimated from them, the segmentation network runs on every 10 ms frame\n(scaled with the estimated speed), the character classifier where a character is present,\nthen the temporal filter and the lexicon decoder. Both architectures read identical streams.\n"
    );
    let readers = shipped_readers(pipeline::code::BrailleCode::Grade1Letters)?;
    let speller = Speller::new(Spell::Lexicon);
    let mut right = vec![(0usize, 0usize); readers.len()];
    for row in 0..board.rows.len() {
        let scan = setup.scan(speed, depth, row, world.scan_seed(1, &kind, row, 0, speed, depth));
        let t = Instant::now();
        let s = sim::simulate(&board, &sensor, &scan)?;
        let sim_s = t.elapsed().as_secs_f64();
        let (path, duration) = write_scan(out.join(format!("ev_row{row}_16mm_s.aedat4")), &s, &sensor)?;
        println!(
            "row {row}: truth {:?}: {} events, {duration:.1} s of stream (simulated in {sim_s:.1} s, written to {})",
            s.truth.row_text,
            s.events.len(),
            path.display()
        );
        let truth: Vec<&str> = s.truth.row_text.split_whitespace().collect();
        for ((arch, r), ok) in readers.iter().zip(right.iter_mut()) {
            let t = Instant::now();
            let got = r.read(&s.events, sensor.camera.resolution, pipeline::reader::Timing::ESTIMATED, &speller)?;
            let (words, stats) = (got.words, got.stats);
            let took = t.elapsed().as_secs_f64();
            let read: Vec<&str> = words.iter().map(|w| w.text.as_str()).collect();
            let raw: Vec<&str> = words.iter().map(|w| w.raw.as_str()).collect();
            // words right, the read line aligned to the printed one (a word split in two is wrong)
            let hits = experiments::eval::scoring::EditCounts::align(&truth, &read).hits;
            ok.0 += hits;
            ok.1 += truth.len();
            println!(
                "  {:<6} read {:?} (letters as registered: {:?}) at a speed it estimated from the events, {}: {hits}/{} words right, in {:.2} s = {:.1}% of the stream's duration ({} frames, classifier on {})",
                arch,
                read.join(" "),
                raw.join(" "),
                stats.speed_mm_s.map_or("none".into(), |v| format!("{v:.1} mm/s")),
                truth.len(),
                took,
                100.0 * took / duration.max(1e-9),
                stats.frames,
                stats.classifier_calls
            );
        }
    }
    for ((arch, _), (hits, n)) in readers.iter().zip(&right) {
        println!("{arch}: {hits}/{n} words right on the two rows (SIMULATED).");
    }
    println!(
        "Read a file yourself: braille read {} --arch snn\nThe speed table (8-64 mm/s and hand-held, 30 scans per row): docs/results/nominal/words.md.\n",
        out.join("ev_row0_16mm_s.aedat4").display()
    );
    Ok(())
}

/// Real Braille: a sentence of the UEB test board (never trained on; a capital, digits,
/// punctuation and Grade 2 contractions) printed in contracted UEB, scanned by the virtual Evetac
/// as in [`read_words`] and read from its raw events by both architectures' cell readers
/// (models/nominal/ueb/), each word's cells back-translated to print by liblouis.
fn read_ueb(out: &Path) -> Result<()> {
    use pipeline::code::BrailleCode;
    use pipeline::reader::{Spell, Speller};
    let code = BrailleCode::UebGrade2;
    let print = "Help is here: call 112 in an emergency.";
    let printed = corpus::boards::parse_print_board(&format!("text:{print}"), code)?;
    let world = corpus::world::World::test(sim::Realism::Nominal);
    let setup = world.setup();
    let board = world.board(&setup, &printed.kind)?;
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, world.sensor_seed(0))?;
    let (speed, depth) = (16.0, 1.0);
    println!(
        "Real Braille (SIMULATED): a test sentence in contracted Unified English Braille ({code}),\n{print:?}, on {} rows of at most {} cells, scanned at {speed} mm/s, {depth} mm deep.\nEach architecture's cell reader (the 63 cells) reads the events, and liblouis translates each\nword's cells back to print.\n",
        board.rows.len(),
        corpus::boards::UEB_ROW_CELLS
    );
    let readers = shipped_readers(code)?;
    let speller = Speller::in_code(Spell::Lexicon, code)?;
    let mut right = vec![(0usize, 0usize); readers.len()];
    for (row, row_print) in printed.print_rows.iter().enumerate() {
        let scan = setup.scan(speed, depth, row, world.scan_seed(1, &printed.kind, row, 0, speed, depth));
        let s = sim::simulate(&board, &sensor, &scan)?;
        let (path, duration) = write_scan(out.join(format!("ueb_row{row}_16mm_s.aedat4")), &s, &sensor)?;
        println!(
            "row {row}: print {row_print:?}, cells {:?}: {} events, {duration:.1} s of stream (written to {})",
            s.truth.row_text,
            s.events.len(),
            path.display()
        );
        let truth: Vec<&str> = row_print.split_whitespace().collect();
        for ((arch, r), ok) in readers.iter().zip(right.iter_mut()) {
            let got = r.read(&s.events, sensor.camera.resolution, pipeline::reader::Timing::ESTIMATED, &speller)?;
            let read: Vec<&str> = got.words.iter().map(|w| w.text.as_str()).collect();
            let raw: Vec<&str> = got.words.iter().map(|w| w.raw.as_str()).collect();
            // words right exactly (case, digits and punctuation count), aligned to the print
            let hits = experiments::eval::scoring::EditCounts::align(&truth, &read).hits;
            ok.0 += hits;
            ok.1 += truth.len();
            println!(
                "  {arch:<6} read cells {:?} -> {:?}: {hits}/{} words right",
                raw.join(" "),
                read.join(" "),
                truth.len()
            );
        }
    }
    for ((arch, _), (hits, n)) in readers.iter().zip(&right) {
        println!("{arch}: {hits}/{n} words of the sentence right, exactly (SIMULATED).");
    }
    println!(
        "Read it yourself: braille read {} --braille ueb-g2\nThe UEB tables (RCB's 63 cells, 24 test sentences at 8-32 mm/s): docs/braille.md.\n",
        out.join("ueb_row0_16mm_s.aedat4").display()
    );
    Ok(())
}

/// Both architectures' shipped readers (models/nominal/) for the print in `code`, ResNet first.
fn shipped_readers(
    code: pipeline::code::BrailleCode,
) -> Result<Vec<(snn::model_file::Arch, pipeline::classify::ReaderModels)>> {
    use pipeline::classify::{ReaderModels, SnnRunner};
    use snn::model_file::Arch;
    let models = crate::common::default_models_dir();
    [Arch::Resnet, Arch::Snn]
        .into_iter()
        .map(|a| {
            let pipeline::shipped::ReaderFiles { segmenter: s, classifier: c } =
                pipeline::shipped::reader_for(&models, a, code);
            Ok((a, ReaderModels::load(&s, &c, SnnRunner::Sliding)?))
        })
        .collect()
}

/// A simulated scan's events written to `path` with its truth beside it; the path back and the
/// stream's duration in seconds.
fn write_scan(path: PathBuf, s: &sim::Scan, sensor: &sim::Sensor) -> Result<(PathBuf, f64)> {
    crate::common::write_events(&path, &s.events, sensor.camera.resolution, true)?;
    experiments::write_json(&crate::common::truth_path(&path), &s.truth, true)?;
    Ok((path, s.events.last().map_or(0.0, |e| e.t_us as f64 / 1e6)))
}
