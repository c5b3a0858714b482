//! The online speed estimator (`pipeline::speed`) on SIMULATED scans: the estimates over the slide
//! of EV rows at four speeds, against the truth, with the test sensor builds.
//!
//! `cargo run --release -p experiments --example speed_estimate [clean|nominal|harsh] [trials]`

use experiments::datasets::World;
use pipeline::speed::{SpeedEstimator, SpeedEstimatorConfig};
use sim::{BoardKind, Realism};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let realism: Realism = match std::env::args().nth(1).as_deref() {
        None | Some("nominal") => Realism::Nominal,
        Some("clean") => Realism::Clean,
        Some("harsh") => Realism::Harsh,
        Some(other) => return Err(format!("unknown preset {other}").into()),
    };
    let trials: u64 = std::env::args().nth(2).map_or(Ok(3), |s| s.parse())?;
    let world = World::test(realism);
    let setup = world.setup();
    let board = world.board(&setup, &BoardKind::Ev)?;
    let sensors = world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    println!("# The online speed estimator on SIMULATED scans\n");
    println!(
        "Regenerate: `cargo run --release -p experiments --example speed_estimate {realism} {trials} > docs/results/speed_estimate.md`. The estimator (pipeline/src/speed.rs) is contrast maximisation over a 250 ms window of events, with no truth and no hint. Errors are against the scan's mean speed, so the arm's speed ripple (3.5% at `nominal`) counts as error.\n"
    );
    println!(
        "SIMULATED EV rows at {realism}, test sensor builds, {trials} trials a row, 1.5 mm; every estimate during the slide from 0.3 s after its start:\n"
    );
    println!("| speed | estimates | median error | mean absolute error | largest error | direction right |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for speed in [8.0, 16.0, 24.0, 32.0] {
        let mut errors = Vec::new();
        let mut forward = 0usize;
        for row in 0..board.rows.len() {
            for trial in 0..trials {
                let seed = world.scan_seed(7, &BoardKind::Ev, row, trial, speed, 1.5);
                let sensor = &sensors[(trial % sensors.len() as u64) as usize];
                let s = sim::simulate(&board, sensor, &setup.scan(speed, 1.5, row, seed))?;
                let tl = &s.truth.timeline;
                let mut est = SpeedEstimator::new(SpeedEstimatorConfig::default(), s.truth.resolution)?;
                for e in &s.events {
                    est.push(e);
                    if est.due(e.t_us)
                        && let Some(x) = est.update(e.t_us)
                    {
                        // the slide, a window after its start (the window must be full of motion)
                        let t = x.t_us as f64 / 1e6;
                        if t > tl.slide_start_s + 0.3 && t < tl.slide_end_s {
                            errors.push(x.speed_mm_s / speed - 1.0);
                            forward += x.forward as usize;
                        }
                    }
                }
            }
        }
        let n = errors.len();
        let mut abs: Vec<f64> = errors.iter().map(|e| e.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let mut sorted = errors.clone();
        sorted.sort_by(f64::total_cmp);
        println!(
            "| {speed} mm/s | {n} | {:+.1}% | {:.1}% | {:.1}% | {forward}/{n} |",
            100.0 * sorted.get(n / 2).copied().unwrap_or(f64::NAN),
            100.0 * abs.iter().sum::<f64>() / n.max(1) as f64,
            100.0 * abs.last().copied().unwrap_or(f64::NAN),
        );
    }
    Ok(())
}
