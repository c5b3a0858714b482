//! What a word costs to read from a live sensor (SIMULATED scans): rows of a board served over
//! TCP in DV's network framing at the recorded pace by a stand-in sensor on a thread
//! ([`encoders::formats::net::serve`]), read as `braille read tcp://HOST:PORT` reads a real one
//! ([`pipeline::source::read_source`] over [`encoders::formats::net::connect`]), by each
//! architecture's shipped reader in turn on the same rows.

use crate::error::Result;
use crate::eval::scoring::EditCounts;
use corpus::scans::{RowStream, Scanner};
use encoders::formats::OpenOptions;
use encoders::formats::net::{self, ConnectOptions, ReplayOptions, ReplayStats};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, Timing};
use pipeline::source::ReadSummary;
use serde::Serialize;
use sim::{BoardKind, Direction, Realism};
use snn::model_file::Arch;
use std::net::TcpListener;
use std::path::Path;

/// Which rows are served, and how.
#[derive(Debug, Clone, Serialize)]
pub struct LiveSpec {
    pub board: BoardKind,
    /// Rows served one after another (the board's rows in order, then again with new trials).
    pub rows: usize,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub seed: u64,
    pub realism: Realism,
    /// The sensor build (the world's first test build).
    pub sensor_seed: u64,
    /// Silence between rows, in s (the sensor lifted and moved to the next row).
    pub gap_s: f64,
    /// Stream time per wall time (1: the recorded pace).
    pub pace: f64,
}

/// One architecture's reader on the served rows.
#[derive(Debug, Clone, Serialize)]
pub struct LiveRun {
    pub arch: Arch,
    /// Printed words, and word accuracy (1 - WER) and percent correct over all of them.
    pub words_printed: usize,
    pub word_accuracy: f64,
    pub percent_correct: f64,
    pub summary: ReadSummary,
    pub served: ReplayStats,
}

/// The result: the spec and one run per architecture.
#[derive(Debug, Clone, Serialize)]
pub struct LiveBench {
    pub data: &'static str,
    pub spec: LiveSpec,
    pub runs: Vec<LiveRun>,
}

impl LiveSpec {
    /// `rows` rows of the EV board at `nominal` on its first test build, the test seed, a second
    /// between rows, served at the recorded pace.
    pub fn ev_nominal(rows: usize, speed_mm_s: f64, depth_mm: f64) -> LiveSpec {
        let realism = Realism::Nominal;
        LiveSpec {
            board: BoardKind::Ev,
            rows,
            speed_mm_s,
            depth_mm,
            seed: corpus::world::TEST_SEED,
            realism,
            sensor_seed: corpus::World::test(realism).sensor_seed(0),
            gap_s: 1.0,
            pace: 1.0,
        }
    }
}

/// What `braille bench --live` prints: a line per architecture.
impl std::fmt::Display for LiveBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let spec = &self.spec;
        writeln!(
            f,
            "SIMULATED: {} rows of {} at {} mm/s, {} mm, served over TCP at the recorded pace",
            spec.rows,
            spec.board.name(),
            spec.speed_mm_s,
            spec.depth_mm
        )?;
        let ms = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.1} ms"));
        for run in &self.runs {
            let s = &run.summary;
            writeln!(
                f,
                "{}: {} of {} words timed; word latency p50 {}, p99 {}, max {} (a word's last detection arriving to the word printed, the word gap included); completion p50 {}, p99 {}; word accuracy {:.3} (1 - WER), percent correct {:.3}; {:.1} s of stream in {:.1} s",
                run.arch,
                s.words_timed,
                run.words_printed,
                ms(s.word_latency_ms_p50),
                ms(s.word_latency_ms_p99),
                ms(s.word_latency_ms_max),
                ms(s.completion_latency_ms_p50),
                ms(s.completion_latency_ms_p99),
                run.word_accuracy,
                run.percent_correct,
                s.stream_s,
                s.read_s
            )?;
        }
        Ok(())
    }
}

/// Serves `spec`'s rows to each architecture's shipped reader in `models` (estimated timing,
/// lexicon spelling), one after the other.
pub fn live(spec: &LiveSpec, models: &Path, archs: &[Arch]) -> Result<LiveBench> {
    let mut runs = Vec::new();
    for &arch in archs {
        let files = pipeline::shipped::reader_in(models, arch);
        let readers = ReaderModels::load(&files.segmenter, &files.classifier, SnnRunner::Sliding)?;
        let scanner = Scanner::new(
            spec.board.clone(),
            None,
            spec.sensor_seed,
            spec.realism,
            encoders::Resolution::DVXPLORER,
            spec.speed_mm_s,
            spec.depth_mm,
            Direction::Forward,
            spec.seed,
        )?;
        let resolution = scanner.sensor.camera.resolution;
        let listener = TcpListener::bind("127.0.0.1:0")
            .map_err(|e| encoders::Error::Io { path: "tcp://127.0.0.1:0".into(), source: e })?;
        let address = listener.local_addr().map_err(|e| encoders::Error::Io { path: "tcp://".into(), source: e })?;
        let options = ReplayOptions { pace: spec.pace, ..ReplayOptions::default() };
        let (rows, gap_us) = (spec.rows, (spec.gap_s * 1e6) as i64);
        let server = std::thread::spawn(move || -> encoders::Result<(ReplayStats, Vec<String>)> {
            let mut stream = RowStream::new(scanner, Some(rows), None, gap_us);
            let stats = net::serve(&listener, &mut stream, resolution, &options)?;
            Ok((stats, stream.texts))
        });
        let mut source = net::connect(&address.to_string(), &OpenOptions::default(), &ConnectOptions::default())?;
        let mut read: Vec<String> = Vec::new();
        let name = format!("{}{address}", net::SCHEME);
        let summary = pipeline::source::read_source(
            &mut source,
            &name,
            &readers,
            Timing::ESTIMATED,
            resolution,
            &pipeline::reader::Speller::new(Spell::Lexicon),
            &mut |w| {
                if !w.unreadable {
                    read.push(w.text.clone());
                }
                Ok(())
            },
        )?;
        let (served, texts) = server.join().expect("the server thread does not panic")?;
        let truth: Vec<String> = texts.iter().flat_map(|t| t.split_whitespace().map(str::to_string)).collect();
        let edits = EditCounts::align(&truth, &read);
        runs.push(LiveRun {
            arch,
            words_printed: truth.len(),
            word_accuracy: edits.accuracy(),
            percent_correct: edits.percent_correct(),
            summary,
            served,
        });
    }
    Ok(LiveBench {
        data: "simulated (virtual Evetac) rows served over TCP at the recorded pace",
        spec: spec.clone(),
        runs,
    })
}
