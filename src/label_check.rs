//! `braille label-check`: the paper's labeling pipeline against the simulator's ground truth on
//! fresh simulated scans.

use anyhow::Result;
use pipeline::labeling::{LabelerConfig, label, score};
use rayon::prelude::*;
use serde::Serialize;
use sim::{Board, BoardGeometry, BoardKind, ScanConfig};

#[derive(clap::Args)]
pub struct Args {
    /// Scans per board row and condition.
    #[arg(long, default_value_t = 4)]
    trials: u64,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Row {
    board: String,
    speed_mm_s: f64,
    depth_mm: f64,
    scans: usize,
    characters: usize,
    correct: usize,
    accuracy: f64,
    count_matched: usize,
}

pub fn run(args: Args) -> Result<()> {
    let sensor = crate::simulate::sensor(encoders::Resolution::DVXPLORER, 1)?;
    let cfg = LabelerConfig::default();
    // The paper's training boards at its training condition, the test board over depth, and
    // every board kind over speed.
    let mut conditions: Vec<(BoardKind, f64, f64)> = vec![(BoardKind::Sab, 8.0, 1.5), (BoardKind::Un, 8.0, 1.5)];
    conditions.extend([0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5].map(|d| (BoardKind::Rab, 8.0, d)));
    conditions.extend([16.0, 24.0, 32.0].map(|v| (BoardKind::Rab, v, 1.5)));
    conditions.extend([8.0, 16.0, 24.0, 32.0].map(|v| (BoardKind::Ev, v, 1.5)));
    let rows: Vec<Result<Row>> = conditions
        .par_iter()
        .map(|(kind, speed, depth)| {
            let board = Board::new(kind.clone(), BoardGeometry::default(), Board::default_seed(kind))?;
            let (mut chars, mut correct, mut matched, mut scans) = (0, 0, 0, 0);
            for row in 0..board.rows.len() {
                for trial in 0..args.trials {
                    let scan = ScanConfig {
                        speed_mm_s: *speed,
                        depth_mm: *depth,
                        row,
                        seed: crate::simulate::trial_seed(args.seed, row, trial),
                        ..ScanConfig::default()
                    };
                    let s = sim::simulate(&board, &sensor, &scan)?;
                    let n = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).count();
                    let l = label(&s.events, sensor.camera.resolution, *speed, n, &cfg)?;
                    let sc = score(&l, &s.truth, &cfg);
                    chars += sc.expected;
                    correct += sc.correct;
                    matched += l.count_matched as usize;
                    scans += 1;
                }
            }
            Ok(Row {
                board: kind.name(),
                speed_mm_s: *speed,
                depth_mm: *depth,
                scans,
                characters: chars,
                correct,
                accuracy: correct as f64 / chars.max(1) as f64,
                count_matched: matched,
            })
        })
        .collect();
    let rows = rows.into_iter().collect::<Result<Vec<_>>>()?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    println!("Labeling pipeline against ground truth (SIMULATED scans, virtual Evetac):\n");
    println!(
        "| board | speed (mm/s) | depth (mm) | scans | count matched | windows right |\n| --- | --- | --- | --- | --- | --- |"
    );
    for r in &rows {
        println!(
            "| {} | {} | {} | {} | {}/{} | {}/{} ({:.1}%) |",
            r.board,
            r.speed_mm_s,
            r.depth_mm,
            r.scans,
            r.count_matched,
            r.scans,
            r.correct,
            r.characters,
            100.0 * r.accuracy
        );
    }
    Ok(())
}
