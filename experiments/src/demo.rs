//! The built-in demonstration (`braille demo`), written as it runs: both readers on SIMULATED
//! scans of the EV board and of a contracted UEB sentence, then the shipped SNN on real iCub
//! recordings spelled into a stream, written as AEDAT 4.0 and read back.

use crate::eval::scoring::EditCounts;
use crate::{Error, Result};
use encoders::Event;
use encoders::dataset::Dataset;
use encoders::formats::aedat4::{self, EncoderOptions};
use encoders::formats::{self, AtomicFile, EventSink, OpenOptions};
use encoders::heatmap::{HeatmapConfig, HeatmapEncoder};
use encoders::stats::StreamStats;
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::code::BrailleCode;
use pipeline::reader::{Spell, Speller, Timing};
use pipeline::shipped::{ReaderFiles, Shipped};
use sim::BoardKind;
use snn::model_file::Arch;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// What the demonstration reads and where it writes (with the `clap` feature, `braille demo`'s
/// arguments).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct DemoSpec {
    /// Analog dataset folder (raw.csv, split.csv) [default: the repository's data/icub_braille/raw1350].
    #[cfg_attr(feature = "clap", arg(long))]
    pub data: Option<PathBuf>,
    /// Sampling period of the analog data, in microseconds (iCub: 40 Hz).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 25_000))]
    pub period_us: i64,
    /// Sigma-delta threshold, in taxel units.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 2.0))]
    pub threshold: f32,
    /// Text to spell from recorded test-split letters (A-Z and spaces).
    #[cfg_attr(feature = "clap", arg(long, default_value = "HELLO WORLD"))]
    pub text: String,
    /// Folder for the demo's event files [default: `braille-demo` in the system's temporary directory].
    #[cfg_attr(feature = "clap", arg(long))]
    pub out: Option<PathBuf>,
    /// The shipped models ([`Shipped::repo`]).
    #[cfg_attr(feature = "clap", arg(skip = Shipped::repo()))]
    pub shipped: Shipped,
}

impl DemoSpec {
    /// The folder of the event files.
    fn out_dir(&self) -> PathBuf {
        self.out.clone().unwrap_or_else(|| std::env::temp_dir().join("braille-demo"))
    }
}

/// A line of the demonstration, to `w` (an error names the output).
macro_rules! say {
    ($w:expr, $($arg:tt)*) => {
        writeln!($w, $($arg)*).map_err(|source| Error::Io { path: "the demonstration's output".into(), source })?
    };
}

/// Runs the demonstration, writing what it does and finds to `w` as it goes.
pub fn run(spec: &DemoSpec, w: &mut dyn Write) -> Result<()> {
    let Some(data) = &spec.data else {
        return Err(Error::Options("the demonstration needs a dataset folder (`data`)".into()));
    };
    let out = &spec.out_dir();
    std::fs::create_dir_all(out).map_err(|source| Error::Io { path: out.clone(), source })?;
    say!(w, "braille demo\n");
    read_words(spec, w)?;
    read_ueb(spec, w)?;
    say!(w, "Real tactile recordings (iCub fingertip, not Evetac): events, files, the SNN on the engine.\n");
    let t = Instant::now();
    let ds = Dataset::load(data, spec.period_us)?;
    say!(
        w,
        "1. Loaded {} ({} samples, {} classes, {} taxels at {:.0} Hz) in {:.2} s: iCub fingertip Braille\n   recordings, Müller-Cleve et al. 2022 (real sensor data).",
        data.display(),
        ds.samples.len(),
        ds.classes.len(),
        ds.channels,
        1e6 / spec.period_us as f64,
        t.elapsed().as_secs_f64()
    );

    // A stream that spells the text from test-split recordings (sigma-delta encoded pressure,
    // 255 - reading), letter after letter.
    let t = Instant::now();
    let spelled = crate::eval::tactile::spell_stream(&ds, &spec.text, spec.threshold, spec.period_us)?;
    say!(
        w,
        "2. Sigma-delta encoded (threshold {}) into {} events, {:.1} per sample, in {:.1} ms.",
        spec.threshold,
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
        return Err(Error::Data { path, what: "did not read back the events written".into() });
    }
    let mut stats = StreamStats::default();
    stats.add(&back);
    say!(
        w,
        "3. Wrote {:?} as one stream of {} events ({:.1} s, ON/OFF {:.2}) to {}\n   (AEDAT 4.0, LZ4, {} taxels as a {} sensor) and read it back identical.",
        spelled,
        stats.events,
        stats.duration_s(),
        stats.on_off_ratio().unwrap_or(f64::NAN),
        path.display(),
        ds.channels,
        info.resolution.map_or("?".into(), |r| r.to_string()),
    );

    // Heat map in 250 ms bins: one text row per taxel, one column per bin.
    let bin_us = 250_000;
    let enc = HeatmapEncoder::new(HeatmapConfig { bin_us, pool: 1, sensor: resolution, mask_cols: None })?;
    let bins = (offset_us / bin_us) as usize;
    let map = enc.encode(&back, 0, bins);
    say!(
        w,
        "4. Heat map (eq. 4 of the paper), {} ms bins, ON + OFF events per taxel (. 1-2, o 3-5, O 6+):",
        bin_us / 1000
    );
    let per_letter = (sample_us / bin_us) as usize;
    let header: String = spelled.chars().map(|c| format!("{c:<per_letter$}")).collect();
    say!(w, "           {header}");
    for taxel in 0..ds.channels {
        let row: String = (0..bins)
            .map(|b| match map.get(b, 0, 0, taxel) + map.get(b, 1, 0, taxel) {
                0.0 => ' ',
                n if n <= 2.0 => '.',
                n if n <= 5.0 => 'o',
                _ => 'O',
            })
            .collect();
        say!(w, "  taxel {taxel:>2} {row}");
    }
    let letters = Letters { stream: &back, resolution, truth: &spelled, sample_us, classes: &ds.classes };
    read_letters(spec, &letters, w)?;
    say!(w, "\nMore: `braille report words`, `braille eval words`, `braille eval chars`; see the README.");
    Ok(())
}

/// The spelled stream as read back, and what it spells.
struct Letters<'a> {
    stream: &'a [Event],
    resolution: encoders::Resolution,
    truth: &'a str,
    sample_us: i64,
    classes: &'a [String],
}

/// The shipped iCub SNN reads the stream back, letter by letter (each letter's 2 s slice of the
/// stream), on the event-driven engine.
fn read_letters(spec: &DemoSpec, l: &Letters, w: &mut dyn Write) -> Result<()> {
    let path = spec.shipped.icub("raw1350", pipeline::shipped::Variant::Trained);
    let model = pipeline::models::load_snn(&path)?;
    let enc = crate::eval::tactile::encoding_of(&model, &path)?;
    if enc.sigma_delta.as_ref().is_some_and(|sd| sd.threshold != spec.threshold) || model.classes != l.classes {
        say!(w, "4b. (skipped: the shipped SNN was trained with another encoding or classes than this demo's)");
        return Ok(());
    }
    let t = Instant::now();
    let n = l.truth.chars().count();
    let (read, synops) = crate::eval::tactile::read_letters(&model, &path, l.stream, l.resolution, n, l.sample_us)?;
    let right = read.chars().zip(l.truth.chars()).filter(|(a, b)| a == b).count();
    say!(
        w,
        "4b. The shipped SNN ({}) read the stream back letter by letter on the event-driven\n    engine: {:?} -> {:?}, {}/{} letters right, in {:.1} ms for {:.0} s of stream ({} synaptic\n    operations). Real recordings; each letter's 2 s slice is given.",
        path.display(),
        l.truth,
        read,
        right,
        n,
        t.elapsed().as_secs_f64() * 1e3,
        (n as i64 * l.sample_us) as f64 / 1e6,
        synops
    );
    Ok(())
}

/// The main job: both rows of the paper's EV board scanned at 16 mm/s by the virtual Evetac at the
/// `nominal` preset with a test sensor build (SIMULATED), each read from its raw events by both
/// architectures' models trained at `nominal`.
fn read_words(spec: &DemoSpec, w: &mut dyn Write) -> Result<()> {
    let kind = BoardKind::Ev;
    let world = corpus::world::World::test(sim::Realism::Nominal);
    let setup = world.setup();
    let board = world.board(&setup, &kind)?;
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, world.sensor_seed(0))?;
    let (speed, depth) = (16.0, 1.5);
    say!(
        w,
        "Reading Braille words from raw events (SIMULATED: virtual Evetac scans, not recordings).\nThe EV board at {speed} mm/s, {depth} mm deep, on the `nominal` simulator (gel dynamics, print\ntexture, drift, a sensor build no model was trained on). Each scan is read from its events\nalone: the speed is estimated from them, the segmentation network runs on every 10 ms frame\n(scaled with the estimated speed), the character classifier where a character is present,\nthen the temporal filter and the lexicon decoder. Both architectures read identical streams.\n"
    );
    let readers = shipped_readers(&spec.shipped, BrailleCode::Grade1Letters)?;
    let speller = Speller::new(Spell::Lexicon);
    let mut right = vec![(0usize, 0usize); readers.len()];
    for row in 0..board.rows.len() {
        let scan = setup.scan(speed, depth, row, world.scan_seed(1, &kind, row, 0, speed, depth));
        let t = Instant::now();
        let s = sim::simulate(&board, &sensor, &scan)?;
        let sim_s = t.elapsed().as_secs_f64();
        let (path, duration) = write_scan(spec.out_dir().join(format!("ev_row{row}_16mm_s.aedat4")), &s, &sensor)?;
        say!(
            w,
            "row {row}: truth {:?}: {} events, {duration:.1} s of stream (simulated in {sim_s:.1} s, written to {})",
            s.truth.row_text,
            s.events.len(),
            path.display()
        );
        let truth: Vec<&str> = s.truth.row_text.split_whitespace().collect();
        for ((arch, r), ok) in readers.iter().zip(right.iter_mut()) {
            let t = Instant::now();
            let got = r.read(&s.events, sensor.camera.resolution, Timing::ESTIMATED, &speller)?;
            let (words, stats) = (got.words, got.stats);
            let took = t.elapsed().as_secs_f64();
            let read: Vec<&str> = words.iter().filter(|w| !w.unreadable).map(|w| w.text.as_str()).collect();
            let raw: Vec<&str> = words.iter().map(|w| w.raw.as_str()).collect();
            // words right, the read line aligned to the printed one (a word split in two is wrong)
            let hits = EditCounts::align(&truth, &read).hits;
            ok.0 += hits;
            ok.1 += truth.len();
            say!(
                w,
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
        say!(w, "{arch}: {hits}/{n} words right on the two rows (SIMULATED).");
    }
    say!(
        w,
        "Read a file yourself: braille read {} --arch snn\nThe speed table (8-64 mm/s and hand-held, 30 scans per row): docs/results/nominal/words.md.\n",
        spec.out_dir().join("ev_row0_16mm_s.aedat4").display()
    );
    Ok(())
}

/// Real Braille: a sentence of the UEB test board (never trained on; a capital, digits,
/// punctuation and Grade 2 contractions) printed in contracted UEB, scanned by the virtual Evetac
/// as in [`read_words`] and read from its raw events by both architectures' cell readers
/// (models/nominal/ueb/), each word's cells back-translated to print by liblouis.
fn read_ueb(spec: &DemoSpec, w: &mut dyn Write) -> Result<()> {
    let code = BrailleCode::UebGrade2;
    let print = "Help is here: call 112 in an emergency.";
    let printed = corpus::boards::parse_print_board(&format!("text:{print}"), code)?;
    let world = corpus::world::World::test(sim::Realism::Nominal);
    let setup = world.setup();
    let board = world.board(&setup, &printed.kind)?;
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, world.sensor_seed(0))?;
    let (speed, depth) = (16.0, 1.0);
    say!(
        w,
        "Real Braille (SIMULATED): a test sentence in contracted Unified English Braille ({code}),\n{print:?}, on {} rows of at most {} cells, scanned at {speed} mm/s, {depth} mm deep.\nEach architecture's cell reader (the 63 cells) reads the events, and liblouis translates each\nword's cells back to print.\n",
        board.rows.len(),
        corpus::boards::UEB_ROW_CELLS
    );
    let readers = shipped_readers(&spec.shipped, code)?;
    let speller = Speller::in_code(Spell::Lexicon, code)?;
    let mut right = vec![(0usize, 0usize); readers.len()];
    for (row, row_print) in printed.print_rows.iter().enumerate() {
        let scan = setup.scan(speed, depth, row, world.scan_seed(1, &printed.kind, row, 0, speed, depth));
        let s = sim::simulate(&board, &sensor, &scan)?;
        let (path, duration) = write_scan(spec.out_dir().join(format!("ueb_row{row}_16mm_s.aedat4")), &s, &sensor)?;
        say!(
            w,
            "row {row}: print {row_print:?}, cells {:?}: {} events, {duration:.1} s of stream (written to {})",
            s.truth.row_text,
            s.events.len(),
            path.display()
        );
        let truth: Vec<&str> = row_print.split_whitespace().collect();
        for ((arch, r), ok) in readers.iter().zip(right.iter_mut()) {
            let got = r.read(&s.events, sensor.camera.resolution, Timing::ESTIMATED, &speller)?;
            let read: Vec<&str> = got.words.iter().filter(|w| !w.unreadable).map(|w| w.text.as_str()).collect();
            let raw: Vec<&str> = got.words.iter().map(|w| w.raw.as_str()).collect();
            // words right exactly (case, digits and punctuation count), aligned to the print
            let hits = EditCounts::align(&truth, &read).hits;
            ok.0 += hits;
            ok.1 += truth.len();
            say!(
                w,
                "  {arch:<6} read cells {:?} -> {:?}: {hits}/{} words right",
                raw.join(" "),
                read.join(" "),
                truth.len()
            );
        }
    }
    for ((arch, _), (hits, n)) in readers.iter().zip(&right) {
        say!(w, "{arch}: {hits}/{n} words of the sentence right, exactly (SIMULATED).");
    }
    say!(
        w,
        "Read it yourself: braille read {} --braille ueb-g2\nThe UEB tables (RCB's 63 cells, 24 test sentences at 8-32 mm/s): docs/braille.md.\n",
        spec.out_dir().join("ueb_row0_16mm_s.aedat4").display()
    );
    Ok(())
}

/// Both architectures' shipped readers (models/nominal/) for the print in `code`, ResNet first.
fn shipped_readers(shipped: &Shipped, code: BrailleCode) -> Result<Vec<(Arch, ReaderModels)>> {
    let models = shipped.dir(pipeline::shipped::Preset::Nominal);
    [Arch::Resnet, Arch::Snn]
        .into_iter()
        .map(|a| {
            let ReaderFiles { segmenter: s, classifier: c } = pipeline::shipped::reader_for(&models, a, code);
            Ok((a, ReaderModels::load(&s, &c, SnnRunner::Sliding)?))
        })
        .collect()
}

/// A simulated scan's events written to `path` with its truth beside it; the path back and the
/// stream's duration in seconds.
fn write_scan(path: PathBuf, s: &sim::Scan, sensor: &sim::Sensor) -> Result<(PathBuf, f64)> {
    corpus::scans::write_events(&path, &s.events, sensor.camera.resolution, true)?;
    crate::write_json(&corpus::scans::truth_path(&path), &s.truth, true)?;
    Ok((path, s.events.last().map_or(0.0, |e| e.t_us as f64 / 1e6)))
}
