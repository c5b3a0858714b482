//! The online speed estimator (`pipeline::speed`) on SIMULATED scans: the estimates over the slide
//! of EV rows at the arm's speeds and hand-held, against the speed under the sensor, with the test
//! sensor builds; and what estimating costs.
//!
//! `cargo run --release -p experiments --example speed_estimate [clean|nominal|harsh] [trials] [default|exhaustive|builds] [EV|VAL] [window_mm] [min_window_ms] [max_mm_s]`
//! (`exhaustive`: the reference configuration, the whole range at every update; `VAL`: the
//! validation board with the training sensor builds and the validation seed, where the
//! estimator's settings are chosen; EV with the test builds is the reported test; `builds`: the
//! error build by build, with each build's optics, over the training and test builds and eight
//! more drawn as they are, 101-110).

use corpus::world::World;
use experiments::eval::words::truth_speed_at;
use pipeline::speed::{SpeedEstimate, SpeedEstimator, SpeedEstimatorConfig};
use sim::{BoardKind, Realism};
use std::time::Instant;

/// Runs the estimator over a scan: its estimates, the estimator (its counters) and the seconds
/// it took (pushing every event and every update).
fn run(
    s: &sim::Scan,
    cfg: &SpeedEstimatorConfig,
) -> Result<(Vec<SpeedEstimate>, SpeedEstimator, f64), Box<dyn std::error::Error>> {
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
    Ok((given, est, start.elapsed().as_secs_f64()))
}

/// The estimates during the slide, a window after its start (the window must be full of motion),
/// each with its error relative to the speed under the sensor.
fn on_slide<'a>(s: &'a sim::Scan, given: &'a [SpeedEstimate]) -> impl Iterator<Item = (&'a SpeedEstimate, f64)> + 'a {
    let tl = &s.truth.timeline;
    given.iter().filter_map(move |x| {
        let t = x.t_us as f64 / 1e6;
        (t > tl.slide_start_s + 0.3 && t < tl.slide_end_s)
            .then(|| (x, x.speed_mm_s / truth_speed_at(&s.truth, t) - 1.0))
    })
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x.get(x.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The estimator's error build by build: each build's field of view (its optics), the scale error
/// the estimator's fixed calibration (18.6 mm) makes on it, and the median error of the estimates
/// on EV rows at 8 and 32 mm/s.
fn by_build(realism: Realism, trials: u64, args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let world = World::test(realism);
    let setup = world.setup();
    let board = world.board(&setup, &BoardKind::Ev)?;
    let cfg = SpeedEstimatorConfig::default();
    println!("# The online speed estimator across sensor builds (SIMULATED)\n");
    println!(
        "Regenerate: `cargo run --release -p experiments --example speed_estimate {}`. EV rows at `{realism}`, {trials} trials a row, 1.5 mm, seed 7, the default estimator (calibrated for an 18.6 mm field of view). A build's optics scale its image (`SensorVariation::fov_rel_sigma`); the estimator measures pixels per second, so its estimate in mm/s is off by the build's scale, expected `18.6 / fov - 1`. Builds 1-4 train the models, 101-102 test them, 103-110 are more builds drawn the same way.\n",
        args.join(" ")
    );
    println!(
        "| build | field of view (mm) | expected scale error | median error at 8 mm/s | median error at 32 mm/s |"
    );
    println!("| --- | --- | --- | --- | --- |");
    let mut rows = Vec::new();
    for build in corpus::world::TRAIN_SENSORS.into_iter().chain(101..=110) {
        let sensor = setup.sensor(encoders::Resolution::DVXPLORER, build)?;
        let fov = sensor.camera.fov_width_mm;
        let mut med = Vec::new();
        for speed in [8.0, 32.0] {
            let mut errors = Vec::new();
            for row in 0..board.rows.len() {
                for trial in 0..trials {
                    let seed = world.scan_seed(7, &BoardKind::Ev, row, trial, speed, 1.5);
                    let s = sim::simulate(&board, &sensor, &setup.scan(speed, 1.5, row, seed))?;
                    let (given, _, _) = run(&s, &cfg)?;
                    errors.extend(on_slide(&s, &given).map(|(_, e)| e));
                }
            }
            med.push(median(errors));
        }
        let expected = cfg.fov_width_mm / fov - 1.0;
        println!(
            "| {build} | {fov:.2} | {:+.1}% | {:+.1}% | {:+.1}% |",
            100.0 * expected,
            100.0 * med[0],
            100.0 * med[1]
        );
        rows.push((expected, med));
    }
    let sd = |v: Vec<f64>| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    };
    let column = |k: usize| rows.iter().map(|r| r.1[k]).collect::<Vec<f64>>();
    println!(
        "\nStandard deviations across the {} builds: of the expected scale error {:.1}%, of the median error {:.1}% at 8 mm/s and {:.1}% at 32 mm/s.",
        rows.len(),
        100.0 * sd(rows.iter().map(|r| r.0).collect()),
        100.0 * sd(column(0)),
        100.0 * sd(column(1))
    );
    Ok(())
}

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
    if arg(2) == Some("builds") {
        return by_build(realism, trials, &args);
    }
    let exhaustive = arg(2) == Some("exhaustive");
    let mut cfg = if exhaustive { SpeedEstimatorConfig::exhaustive() } else { SpeedEstimatorConfig::default() };
    // a window length to try on the validation board: mm of motion, and the shortest in ms
    if let Some(w) = arg(4) {
        cfg.window_mm = w.parse()?;
    }
    if let Some(w) = arg(5) {
        cfg.min_window_ms = w.parse()?;
    }
    // the top of the searched range, to try on the validation board
    if let Some(v) = arg(6) {
        cfg.max_mm_s = v.parse()?;
    }
    println!("# The online speed estimator on SIMULATED scans\n");
    let method = if exhaustive {
        format!(
            "the exhaustive reference configuration: every candidate speed of the range at every update, over a fixed {} ms window of up to {} events",
            cfg.window_ms, cfg.max_events
        )
    } else {
        format!(
            "the default configuration: a window of {} mm of motion at the last estimate ({}-{} ms, up to {} events), a search over the whole range of speeds ({}-{} mm/s) at the start and at least every {} ms, and a local search around the last estimate in between",
            cfg.window_mm,
            cfg.min_window_ms,
            cfg.window_ms,
            cfg.max_events,
            cfg.min_mm_s,
            cfg.max_mm_s,
            cfg.global_every_ms
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
    let conditions: Vec<(f64, f64)> = [4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 160.0, 200.0]
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
                let (given, est, busy) = run(&s, &cfg)?;
                busy_s += busy;
                stream_s += s.events.last().map_or(0.0, |e| e.t_us as f64 / 1e6);
                globals += est.global_searches;
                updates += est.updates;
                for (x, error) in on_slide(&s, &given) {
                    errors.push(error);
                    forward += x.forward as usize;
                }
            }
        }
        let n = errors.len();
        let mut abs: Vec<f64> = errors.iter().map(|e| e.abs()).collect();
        abs.sort_by(f64::total_cmp);

        let name = if variation > 0.0 {
            format!("{speed} mm/s hand-held ±{:.0}%", 100.0 * variation)
        } else {
            format!("{speed} mm/s")
        };
        println!(
            "| {name} | {n} | {:+.1}% | {:.1}% | {:.1}% | {:.1}% | {forward}/{n} | {globals} of {updates} updates | {:.2}% |",
            100.0 * median(errors.clone()),
            100.0 * abs.iter().sum::<f64>() / n.max(1) as f64,
            100.0 * abs.get(n * 9 / 10).copied().unwrap_or(f64::NAN),
            100.0 * abs.last().copied().unwrap_or(f64::NAN),
            100.0 * busy_s / stream_s.max(f64::MIN_POSITIVE),
        );
    }
    Ok(())
}
