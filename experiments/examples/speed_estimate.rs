//! The online speed estimator (`pipeline::speed`) on SIMULATED scans: the estimates over the slide
//! of EV rows at the arm's speeds and hand-held, against the speed under the sensor, with the test
//! sensor builds; and what estimating costs.
//!
//! `cargo run --release -p experiments --example speed_estimate [clean|nominal|harsh] [trials] [default|exhaustive] [EV|VAL] [window_mm] [min_window_ms]`
//! (`exhaustive`: the reference configuration, the whole range at every update; `VAL`: the
//! validation board with the training sensor builds and the validation seed, where the
//! estimator's settings are chosen; EV with the test builds is the reported test).

use corpus::world::World;
use experiments::eval::words::truth_speed_at;
use pipeline::speed::{SpeedEstimator, SpeedEstimatorConfig};
use sim::{BoardKind, Realism};
use std::time::Instant;

/// Hand-held rows swing their speed by this much around the mean (as the words table's).
const HAND_VARIATION: f64 = 0.4;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let realism: Realism = match arg(0) {
        None | Some("nominal") => Realism::Nominal,
        Some("clean") => Realism::Clean,
        Some("harsh") => Realism::Harsh,
        Some(other) => return Err(format!("unknown preset {other}").into()),
    };
    let trials: u64 = arg(1).map_or(Ok(3), str::parse)?;
    let validation = arg(3) == Some("VAL");
    let (world, kind, seed) = if validation {
        (World::train(realism), BoardKind::Val, 2_000_003)
    } else {
        (World::test(realism), BoardKind::Ev, 7)
    };
    let setup = world.setup();
    let board = world.board(&setup, &kind)?;
    let sensors = world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    let exhaustive = arg(2) == Some("exhaustive");
    let mut cfg = if exhaustive { SpeedEstimatorConfig::exhaustive() } else { SpeedEstimatorConfig::default() };
    // a window length to try on the validation board: mm of motion, and the shortest in ms
    if let Some(w) = arg(4) {
        cfg.window_mm = w.parse()?;
    }
    if let Some(w) = arg(5) {
        cfg.min_window_ms = w.parse()?;
    }
    println!("# The online speed estimator on SIMULATED scans\n");
    let method = if exhaustive {
        format!(
            "the exhaustive reference configuration: every candidate speed of the range at every update, over a fixed {} ms window of up to {} events",
            cfg.window_ms, cfg.max_events
        )
    } else {
        format!(
            "the default configuration: a window of {} mm of motion at the last estimate ({}-{} ms, up to {} events), a search over the whole range of speeds at the start and at least every {} ms, and a local search around the last estimate in between",
            cfg.window_mm, cfg.min_window_ms, cfg.window_ms, cfg.max_events, cfg.global_every_ms
        )
    };
    println!(
        "Regenerate: `cargo run --release -p experiments --example speed_estimate {}`. The estimator (pipeline/src/speed.rs) is contrast maximisation, with no truth and no hint, here in {method}. Each estimate is compared with the speed under the sensor when it is given (the simulated motion, with its ripple and swings), so the lag of an online estimate behind a changing speed counts as error.\n",
        args.join(" ")
    );
    println!(
        "SIMULATED {} rows at {realism}, {} sensor builds, {trials} trials a row, 1.5 mm; every estimate during the slide from 0.3 s after its start. Hand-held rows swing the speed by ±{:.0}% around the mean (1-5 Hz). Cost: the estimator's time (every event pushed, every update) on one core, over the stream's duration.\n",
        kind.name(),
        if validation { "training" } else { "test" },
        100.0 * HAND_VARIATION
    );
    println!(
        "| speed | estimates | median error | mean absolute error | 90th percentile | largest error | direction right | whole-range searches | cost |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    let conditions: Vec<(f64, f64)> = [8.0, 16.0, 24.0, 32.0, 48.0, 64.0]
        .into_iter()
        .map(|s| (s, 0.0))
        .chain([(16.0, HAND_VARIATION), (32.0, HAND_VARIATION)])
        .collect();
    for (speed, variation) in conditions {
        let mut errors = Vec::new();
        let (mut forward, mut globals, mut updates) = (0usize, 0u64, 0u64);
        let (mut busy_s, mut stream_s) = (0.0, 0.0);
        for row in 0..board.rows.len() {
            for trial in 0..trials {
                let seed = world.scan_seed(seed, &kind, row, trial, speed, 1.5);
                let sensor = &sensors[(trial % sensors.len() as u64) as usize];
                let scan = sim::ScanConfig { speed_variation: variation, ..setup.scan(speed, 1.5, row, seed) };
                let s = sim::simulate(&board, sensor, &scan)?;
                let tl = &s.truth.timeline;
                let mut est = SpeedEstimator::new(cfg.clone(), s.truth.resolution)?;
                let mut given = Vec::new();
                let start = Instant::now();
                for e in &s.events {
                    est.push(e);
                    if est.due(e.t_us)
                        && let Some(x) = est.update(e.t_us)
                    {
                        given.push(x);
                    }
                }
                busy_s += start.elapsed().as_secs_f64();
                stream_s += s.events.last().map_or(0.0, |e| e.t_us as f64 / 1e6);
                globals += est.global_searches;
                updates += est.updates;
                for x in given {
                    // the slide, a window after its start (the window must be full of motion)
                    let t = x.t_us as f64 / 1e6;
                    if t > tl.slide_start_s + 0.3 && t < tl.slide_end_s {
                        errors.push(x.speed_mm_s / truth_speed_at(&s.truth, t) - 1.0);
                        forward += x.forward as usize;
                    }
                }
            }
        }
        let n = errors.len();
        let mut abs: Vec<f64> = errors.iter().map(|e| e.abs()).collect();
        abs.sort_by(f64::total_cmp);
        let mut sorted = errors.clone();
        sorted.sort_by(f64::total_cmp);
        let name = if variation > 0.0 {
            format!("{speed} mm/s hand-held ±{:.0}%", 100.0 * variation)
        } else {
            format!("{speed} mm/s")
        };
        println!(
            "| {name} | {n} | {:+.1}% | {:.1}% | {:.1}% | {:.1}% | {forward}/{n} | {globals} of {updates} updates | {:.2}% |",
            100.0 * sorted.get(n / 2).copied().unwrap_or(f64::NAN),
            100.0 * abs.iter().sum::<f64>() / n.max(1) as f64,
            100.0 * abs.get(n * 9 / 10).copied().unwrap_or(f64::NAN),
            100.0 * abs.last().copied().unwrap_or(f64::NAN),
            100.0 * busy_s / stream_s.max(f64::MIN_POSITIVE),
        );
    }
    Ok(())
}
