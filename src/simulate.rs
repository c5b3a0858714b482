//! `braille simulate`: scans of Braille boards by the virtual Evetac, written as event files with
//! their ground truth.

use crate::common::{truth_path, write_events};
use anyhow::{Context, Result, bail};
use encoders::Resolution;
use encoders::formats::Format;
use encoders::stats::StreamStats;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use sim::{Board, BoardGeometry, BoardKind, Direction, ScanConfig};
use std::path::PathBuf;

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum DirectionArg {
    Forward,
    Reverse,
}

#[derive(clap::Args)]
pub struct Args {
    /// Board: SAB, UN, RAB, EV, or text:"ANY WORDS" (`/` starts a new row).
    #[arg(long, default_value = "EV")]
    pub board: BoardKind,
    /// Sliding speed (the paper: 8-32 mm/s).
    #[arg(long, default_value_t = 8.0)]
    pub speed: f64,
    /// Indentation depth from first contact (the paper: 0.2-1.5 mm).
    #[arg(long, default_value_t = 1.5)]
    pub depth: f64,
    /// Row to scan [default: every row].
    #[arg(long)]
    pub row: Option<usize>,
    /// Scans per row.
    #[arg(long, default_value_t = 1)]
    pub trials: u64,
    /// Seed of the trials (misalignment, speed ripple, noise).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seed of the printed board's tolerances [default: derived from the board's name].
    #[arg(long)]
    pub board_seed: Option<u64>,
    /// Seed of the sensor's pixels (thresholds, hot pixels).
    #[arg(long, default_value_t = 1)]
    pub sensor_seed: u64,
    #[arg(long, value_enum, default_value = "forward")]
    pub direction: DirectionArg,
    /// Sensor resolution; the field of view stays 18.6 mm wide.
    #[arg(long, default_value = "640x480")]
    pub resolution: Resolution,
    /// An event file (.aedat4, .csv, .npy) for one scan, or a folder for several.
    #[arg(long)]
    pub out: PathBuf,
    /// Replace existing outputs.
    #[arg(long)]
    pub force: bool,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct FileSummary {
    events: PathBuf,
    truth: PathBuf,
    row: usize,
    trial: u64,
    events_count: u64,
    duration_s: f64,
}

#[derive(Serialize)]
struct Summary {
    data: &'static str,
    board: String,
    speed_mm_s: f64,
    depth_mm: f64,
    scans: usize,
    events: u64,
    duration_s: f64,
    on_off_ratio: Option<f64>,
    files: Vec<FileSummary>,
}

pub fn run(args: Args) -> Result<()> {
    let board_seed = args.board_seed.unwrap_or_else(|| Board::default_seed(&args.board));
    let board = Board::new(args.board.clone(), BoardGeometry::default(), board_seed)?;
    let sensor = experiments::datasets::sensor(args.resolution, args.sensor_seed)?;
    let rows: Vec<usize> = match args.row {
        Some(r) if r >= board.rows.len() => {
            bail!("--row {r}: the board has {} rows (0..{})", board.rows.len(), board.rows.len() - 1)
        }
        Some(r) => vec![r],
        None => (0..board.rows.len()).collect(),
    };
    let jobs: Vec<(usize, u64)> = rows.iter().flat_map(|&r| (0..args.trials).map(move |t| (r, t))).collect();
    let single = Format::from_path(&args.out).is_some();
    if single && jobs.len() != 1 {
        bail!("{} scans (rows x trials) need a folder for --out, not a file", jobs.len());
    }
    if !single {
        std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    }
    let direction = match args.direction {
        DirectionArg::Forward => Direction::Forward,
        DirectionArg::Reverse => Direction::Reverse,
    };
    let bar = ProgressBar::new(jobs.len() as u64).with_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} scans {elapsed} (eta {eta})")
            .unwrap_or(ProgressStyle::default_bar()),
    );
    if args.json || jobs.len() == 1 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let name = board.kind.name().replace(['/', ' ', ':', '"'], "_");
    let results: Vec<Result<(FileSummary, StreamStats)>> = jobs
        .par_iter()
        .map(|&(row, trial)| {
            let scan = ScanConfig {
                speed_mm_s: args.speed,
                depth_mm: args.depth,
                row,
                direction,
                seed: experiments::datasets::trial_seed(args.seed, row, trial),
                ..ScanConfig::default()
            };
            let s = sim::simulate(&board, &sensor, &scan)?;
            let events_path = if single {
                args.out.clone()
            } else {
                args.out.join(format!("{name}_row{row}_v{}_d{}_trial{trial}.aedat4", args.speed, args.depth))
            };
            let truth_path = truth_path(&events_path);
            write_events(&events_path, &s.events, args.resolution, args.force)?;
            experiments::write_json(&truth_path, &s.truth, args.force)?;
            let mut stats = StreamStats::default();
            stats.add(&s.events);
            bar.inc(1);
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
    bar.finish_and_clear();
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
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        scans: files.len(),
        events,
        duration_s: duration,
        on_off_ratio: (off > 0).then(|| on as f64 / off as f64),
        files,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        for f in &summary.files {
            println!(
                "{} ({} events, {:.1} s; truth {})",
                f.events.display(),
                f.events_count,
                f.duration_s,
                f.truth.display()
            );
        }
        println!(
            "simulated {} scans of {}: {} events, ON/OFF {:.2}",
            summary.scans,
            summary.board,
            summary.events,
            summary.on_off_ratio.unwrap_or(f64::NAN)
        );
    }
    Ok(())
}
