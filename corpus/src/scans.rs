//! Simulated scans written as event files with their ground truth (`braille simulate`):
//! SIMULATED data, for any board, speed, depth, trial count and seed.

use crate::Progress;
use crate::error::{Error, Result};
use encoders::formats::aedat4::{self, EncoderOptions};
use encoders::formats::{self, AtomicFile, EventSink, Format};
use encoders::stats::StreamStats;
use encoders::{Event, Resolution};
use pipeline::code::BrailleCode;
use rayon::prelude::*;
use serde::Serialize;
use sim::{Board, BoardKind, Direction, ScanConfig};
use std::path::{Path, PathBuf};

/// Which scans to simulate and where to write them (with the `clap` feature, `braille simulate`'s
/// arguments).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct ScanSpec {
    /// Board: SAB, UN, RAB, VAL (validation), EV, VAL-WORDS, VAL-LETTERS (validation words and
    /// letters), ALL-LETTERS, or text:"ANY WORDS" (`/` starts a new row; long rows wrap), its
    /// print written in `--braille`'s code (Unicode Braille cells are printed as they are).
    #[cfg_attr(feature = "clap", arg(long, default_value = "EV"))]
    pub board: String,
    /// The Braille code a `text:` board's print is written in: the paper's letters, or Unified
    /// English Braille uncontracted or contracted (liblouis's tables; `braille translate`).
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = BrailleCode::Grade1Letters))]
    pub braille: BrailleCode,
    /// Sliding speed, mm/s (the paper: 8-32 mm/s).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 8.0))]
    pub speed: f64,
    /// Indentation depth from first contact, mm (the paper: 0.2-1.5 mm).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1.5))]
    pub depth: f64,
    /// Row to scan [default: every row].
    #[cfg_attr(feature = "clap", arg(long))]
    pub row: Option<usize>,
    /// Scans per row.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1))]
    pub trials: u64,
    /// Seed of the trials (misalignment, speed ripple, noise).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 0))]
    pub seed: u64,
    /// Seed of the printed board's tolerances [default: derived from the board's name].
    #[cfg_attr(feature = "clap", arg(long))]
    pub board_seed: Option<u64>,
    /// Seed of the sensor build: its pixels (thresholds, hot pixels) and, beyond `clean`, its gel,
    /// LED and noise rates.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1))]
    pub sensor_seed: u64,
    /// The simulator's nuisances (docs/simulator.md); `clean` is the simulator before them, kept
    /// for regression.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = sim::Realism::Nominal))]
    pub realism: sim::Realism,
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = Direction::Forward))]
    pub direction: Direction,
    /// Stick-slip of the gel on the board's face, seen through a mount of this compliance (um per
    /// N; 33 is `harsh`'s mount, 10 `nominal`'s, 0 a rigid one), the rest of the mount as
    /// `sim::StickSlip::LIGHT_MOUNT` [default: the preset's: none at `clean`].
    #[cfg_attr(feature = "clap", arg(long))]
    pub mount_compliance_um_per_n: Option<f64>,
    /// Sensor resolution; the field of view stays the build's width (18.6 mm by design, drawn
    /// per build beyond `clean`).
    #[cfg_attr(feature = "clap", arg(long, default_value = "640x480"))]
    pub resolution: Resolution,
    /// An event file (.aedat4, .csv, .npy) for one scan, or a folder for several.
    #[cfg_attr(feature = "clap", arg(long))]
    pub out: PathBuf,
    /// Replace existing outputs.
    #[cfg_attr(feature = "clap", arg(long))]
    pub force: bool,
}

impl ScanSpec {
    /// The board the print names, in its code.
    pub fn board_kind(&self) -> Result<BoardKind> {
        crate::boards::parse_board_in(&self.board, self.braille)
    }

    /// Stick-slip through the mount's compliance, beyond the preset's (None: the preset's).
    pub fn stick_slip(&self) -> Option<sim::StickSlip> {
        self.mount_compliance_um_per_n.map(|c| sim::StickSlip::light_mount_with_compliance(c.max(1e-3)))
    }
}

/// One scan written.
#[derive(Debug, Clone, Serialize)]
pub struct FileSummary {
    pub events: PathBuf,
    pub truth: PathBuf,
    pub row: usize,
    pub trial: u64,
    pub events_count: u64,
    pub duration_s: f64,
}

/// What was simulated.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    pub data: &'static str,
    pub board: String,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub scans: usize,
    pub events: u64,
    pub duration_s: f64,
    pub on_off_ratio: Option<f64>,
    pub files: Vec<FileSummary>,
}

/// What `braille simulate` prints: a line per file, then the totals.
impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for s in &self.files {
            let (events, truth) = (s.events.display(), s.truth.display());
            writeln!(f, "{events} ({} events, {:.1} s; truth {truth})", s.events_count, s.duration_s)?;
        }
        writeln!(
            f,
            "simulated {} scans of {}: {} events, ON/OFF {:.2}",
            self.scans,
            self.board,
            self.events,
            self.on_off_ratio.unwrap_or(f64::NAN)
        )
    }
}

/// A board, a sensor and a scan setting, built once; each scan of a row and trial is simulated
/// from them (what `braille simulate` writes, and what the Python package returns).
#[derive(Debug, Clone)]
pub struct Scanner {
    pub setup: sim::Setup,
    pub board: Board,
    pub sensor: sim::Sensor,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub direction: Direction,
    pub seed: u64,
}

impl Scanner {
    /// The board (its tolerances from `board_seed`, or derived from its name), the sensor built
    /// from `sensor_seed` at `resolution`, under `realism`'s nuisances.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        board: BoardKind,
        board_seed: Option<u64>,
        sensor_seed: u64,
        realism: sim::Realism,
        resolution: Resolution,
        speed_mm_s: f64,
        depth_mm: f64,
        direction: Direction,
        seed: u64,
    ) -> Result<Scanner> {
        let board_seed = board_seed.unwrap_or_else(|| Board::default_seed(&board));
        let setup = realism.setup();
        let board = Board::new(board, setup.geometry.clone(), board_seed)?;
        let sensor = setup.sensor(resolution, sensor_seed)?;
        Ok(Scanner { setup, board, sensor, speed_mm_s, depth_mm, direction, seed })
    }

    /// The scanner of `spec`.
    pub fn of(spec: &ScanSpec) -> Result<Scanner> {
        let mut scanner = Scanner::new(
            spec.board_kind()?,
            spec.board_seed,
            spec.sensor_seed,
            spec.realism,
            spec.resolution,
            spec.speed,
            spec.depth,
            spec.direction,
            spec.seed,
        )?;
        if let Some(stick_slip) = spec.stick_slip() {
            scanner.setup.scan.stick_slip = Some(stick_slip);
        }
        Ok(scanner)
    }

    /// Trial `trial` of row `row`: its events and ground truth. The same arguments give the same
    /// scan.
    pub fn scan(&self, row: usize, trial: u64) -> Result<sim::Scan> {
        if row >= self.board.rows.len() {
            return Err(Error::NoSuchRow { row, rows: self.board.rows.len() });
        }
        let scan = ScanConfig {
            direction: self.direction,
            ..self.setup.scan(self.speed_mm_s, self.depth_mm, row, crate::world::trial_seed(self.seed, row, trial))
        };
        Ok(sim::simulate(&self.board, &self.sensor, &scan)?)
    }
}

/// Simulates the scans of `spec` in parallel, each written as it is done (AEDAT 4.0 in a folder,
/// or the format of `out`'s extension), its ground truth beside it.
pub fn simulate_files(spec: &ScanSpec, progress: &dyn Progress) -> Result<Summary> {
    let scanner = Scanner::of(spec)?;
    let board = &scanner.board;
    let rows: Vec<usize> = match spec.row {
        Some(r) if r >= board.rows.len() => {
            return Err(Error::NoSuchRow { row: r, rows: board.rows.len() });
        }
        Some(r) => vec![r],
        None => (0..board.rows.len()).collect(),
    };
    let jobs: Vec<(usize, u64)> = rows.iter().flat_map(|&r| (0..spec.trials).map(move |t| (r, t))).collect();
    let single = Format::from_path(&spec.out).is_some();
    if single && jobs.len() != 1 {
        return Err(Error::NotAFolder { path: spec.out.clone(), scans: jobs.len() });
    }
    if !single {
        std::fs::create_dir_all(&spec.out).map_err(|source| Error::Io { path: spec.out.clone(), source })?;
    }
    if jobs.len() > 1 {
        progress.start("simulating scans", jobs.len() as u64);
    }
    // the board's name in file names; a long text's first characters and a hash of the whole
    let full = crate::boards::board_name(&board.kind);
    let name = if full.chars().count() > 40 {
        format!("{}_{:08x}", full.chars().take(32).collect::<String>(), sim::board::stable_hash(&full) as u32)
    } else {
        full
    }
    .replace(['/', ' ', ':', '"', '(', ')'], "_");
    let results: Vec<Result<(FileSummary, StreamStats)>> = jobs
        .par_iter()
        .map(|&(row, trial)| {
            let s = scanner.scan(row, trial)?;
            let events_path = if single {
                spec.out.clone()
            } else {
                spec.out.join(format!("{name}_row{row}_v{}_d{}_trial{trial}.aedat4", spec.speed, spec.depth))
            };
            let truth_path = truth_path(&events_path);
            write_events(&events_path, &s.events, spec.resolution, spec.force)?;
            crate::write_json(&truth_path, &s.truth, spec.force)?;
            let mut stats = StreamStats::default();
            stats.add(&s.events);
            progress.inc();
            Ok((
                FileSummary {
                    events: events_path,
                    truth: truth_path,
                    row,
                    trial,
                    events_count: stats.events,
                    duration_s: s.truth.timeline.end_s,
                },
                stats,
            ))
        })
        .collect();
    progress.finish();
    let mut files = Vec::new();
    let (mut events, mut on, mut off, mut duration) = (0u64, 0u64, 0u64, 0.0);
    for r in results {
        let (f, s) = r?;
        events += s.events;
        on += s.on;
        off += s.off;
        duration += f.duration_s;
        files.push(f);
    }
    let summary = Summary {
        data: "simulated (virtual Evetac)",
        board: board.kind.name(),
        speed_mm_s: spec.speed,
        depth_mm: spec.depth,
        scans: files.len(),
        events,
        duration_s: duration,
        on_off_ratio: (off > 0).then(|| on as f64 / off as f64),
        files,
    };
    Ok(summary)
}

/// Writes events to `path` in the format of its extension.
pub fn write_events(path: &Path, events: &[Event], resolution: Resolution, force: bool) -> Result<()> {
    let mut sink: Box<dyn EventSink> = match Format::for_output(path)? {
        Format::Aedat4 => {
            let file = AtomicFile::create(path, force)?;
            let opts =
                EncoderOptions { source: "braille simulate (virtual Evetac)".into(), ..EncoderOptions::default() };
            Box::new(aedat4::Encoder::new(file, Some(resolution), opts)?)
        }
        _ => formats::create(path, Some(resolution), force)?,
    };
    sink.write(events)?;
    sink.finish()?;
    Ok(())
}

/// Where a scan's ground truth is written beside its event file: `STEM.truth.json`.
pub fn truth_path(events: &Path) -> PathBuf {
    let stem = events.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    events.with_file_name(format!("{stem}.truth.json"))
}

/// SIMULATED rows scanned one after another as one stream, as a sensor would send them across a
/// session: row after row of the board (trial after trial once every row is done), each shifted
/// to start `gap_us` after the previous one ends. A thread simulates the next row while this one
/// is sent, so memory holds two rows however long the stream. An [`encoders::EventSource`] like a
/// file.
pub struct RowStream {
    rows: std::sync::mpsc::Receiver<Result<(Vec<Event>, String)>>,
    events: Vec<Event>,
    at: usize,
    info: formats::StreamInfo,
    /// The text of every row sent, in order.
    pub texts: Vec<String>,
}

impl RowStream {
    /// Rows of `board` at `nominal` on its first test build with the test seed, forward, for
    /// `stream_s` seconds of stream (a second between rows): a simulated live sensor.
    pub fn nominal_test(
        board: BoardKind,
        resolution: Resolution,
        speed_mm_s: f64,
        depth_mm: f64,
        stream_s: f64,
    ) -> Result<RowStream> {
        let realism = sim::Realism::Nominal;
        let sensor_seed = crate::World::test(realism).sensor_seed(0);
        let seed = crate::world::TEST_SEED;
        let (forward, gap_us) = (Direction::Forward, 1_000_000);
        let scanner = Scanner::new(board, None, sensor_seed, realism, resolution, speed_mm_s, depth_mm, forward, seed)?;
        Ok(RowStream::new(scanner, None, Some(stream_s), gap_us))
    }

    /// `rows` rows of `scanner`'s board (cycling through its rows, one trial at a time), or rows
    /// until `stream_s` seconds of stream have been sent (or both, whichever ends first; neither:
    /// endless); `gap_us` of silence between rows.
    pub fn new(scanner: Scanner, rows: Option<usize>, stream_s: Option<f64>, gap_us: i64) -> RowStream {
        let info = formats::StreamInfo {
            format: Format::Aedat4,
            resolution: Some(scanner.sensor.camera.resolution),
            source: Some("braille (SIMULATED)".into()),
        };
        let (send, receive) = std::sync::mpsc::sync_channel(1);
        std::thread::spawn(move || {
            let n = scanner.board.rows.len();
            let (mut sent, mut offset_us) = (0usize, 0i64);
            while rows.is_none_or(|r| sent < r) && stream_s.is_none_or(|s| (offset_us as f64) < s * 1e6) {
                let row = scanner.scan(sent % n, (sent / n) as u64).map(|scan| {
                    let end = scan.events.last().map_or(0, |e| e.t_us);
                    let mut events = scan.events;
                    for e in &mut events {
                        e.t_us += offset_us;
                    }
                    offset_us += end + gap_us;
                    (events, scan.truth.row_text)
                });
                let failed = row.is_err();
                // the stream was dropped: stop
                if send.send(row).is_err() || failed {
                    return;
                }
                sent += 1;
            }
        });
        RowStream { rows: receive, events: Vec::new(), at: 0, info, texts: Vec::new() }
    }
}

impl encoders::EventSource for RowStream {
    fn info(&self) -> &formats::StreamInfo {
        &self.info
    }

    fn next_chunk(&mut self) -> encoders::Result<Option<&[Event]>> {
        while self.at >= self.events.len() {
            match self.rows.recv() {
                Ok(Ok((events, text))) => {
                    self.events = events;
                    self.texts.push(text);
                    self.at = 0;
                }
                Ok(Err(e)) => {
                    return Err(encoders::Error::Unsupported {
                        path: PathBuf::from("simulated rows"),
                        what: format!("simulating row {}: {e}", self.texts.len()),
                    });
                }
                Err(_) => return Ok(None),
            }
        }
        let end = (self.at + formats::CHUNK_EVENTS).min(self.events.len());
        let chunk = &self.events[self.at..end];
        self.at = end;
        Ok(Some(chunk))
    }

    fn path(&self) -> &Path {
        Path::new("simulated rows")
    }
}
