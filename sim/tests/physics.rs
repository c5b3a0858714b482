//! The eight checks of SIMULATOR.md on fresh simulated scans (physics only; no classifier).

use encoders::Polarity;
use sim::checks::{self, PAPER_DEPTH_GAIN, SPEEDS_MM_S};
use sim::{Board, BoardGeometry, BoardKind, CameraConfig, Direction, GelConfig, ScanConfig, Sensor, simulate};

fn quiet() -> Sensor {
    Sensor::new(CameraConfig::default().without_noise(), GelConfig::default(), 1).unwrap()
}

fn text(t: &str, seed: u64) -> Board {
    Board::new(BoardKind::Text(t.into()), BoardGeometry::default(), seed).unwrap()
}

fn steady(depth_mm: f64, speed_mm_s: f64) -> ScanConfig {
    ScanConfig { depth_mm, speed_mm_s, speed_ripple: 0.0, misalignment_sigma_mm: 0.0, seed: 1, ..ScanConfig::default() }
}

#[test]
fn check1_depth_gain_matches_the_papers_measurement() {
    let (gain, per_dot) = checks::depth(&GelConfig::default(), 4).unwrap();
    for (d, target) in PAPER_DEPTH_GAIN {
        let g = gain[&format!("{d:.1}")];
        assert!((g - target).abs() <= 0.10, "depth {d}: gain {g:.3}, paper {target}");
    }
    // no plateau above the dot height (0.5 mm): events keep growing
    let n: Vec<f64> = per_dot.values().copied().collect();
    assert!(n.windows(2).all(|w| w[1] > w[0]), "{per_dot:?}");
}

#[test]
fn check2_speed_keeps_events_per_pass_and_sets_the_column_lag() {
    // The lag is measured on a board printed without position errors, so that it tests the
    // motion and the measurement, not one board's tolerances.
    let exact = BoardGeometry { position_sigma_mm: 0.0, ..BoardGeometry::default() };
    let c = Board::new(BoardKind::Text("C".into()), exact, 3).unwrap();
    let (dot, sensor) = (text("A", 3), quiet());
    let mut passes = Vec::new();
    let mut rates = Vec::new();
    for v in SPEEDS_MM_S {
        let s = simulate(&dot, &sensor, &steady(1.0, v)).unwrap();
        let tl = s.truth.timeline;
        passes.push(s.events.len() as f64);
        rates.push(s.events.len() as f64 / (tl.slide_end_s - tl.slide_start_s));
        let lag = checks::column_lag_ms(&simulate(&c, &sensor, &steady(1.0, v)).unwrap(), 10).unwrap();
        let expected = 2.5 / v * 1000.0;
        assert!((lag / expected - 1.0).abs() < 0.05, "{v} mm/s: lag {lag:.1} ms, expected {expected:.1}");
    }
    let mean = passes.iter().sum::<f64>() / passes.len() as f64;
    assert!(passes.iter().all(|n| (n / mean - 1.0).abs() <= 0.15), "{passes:?}");
    assert!(rates.windows(2).all(|w| w[1] > w[0]), "event rate must grow with speed: {rates:?}");
}

#[test]
fn check3_polarity_balance_and_edges() {
    let (dot, sensor) = (text("A", 3), quiet());
    let s = simulate(&dot, &sensor, &steady(1.0, 8.0)).unwrap();
    let on = s.events.iter().filter(|e| e.polarity == Polarity::On).count() as f64;
    let ratio = on / (s.events.len() as f64 - on);
    assert!((0.9..=1.2).contains(&ratio), "ON/OFF {ratio:.3}");
    let fwd = checks::edge_polarities(&s.events);
    let rev = checks::edge_polarities(
        &simulate(&dot, &sensor, &ScanConfig { direction: Direction::Reverse, ..steady(1.0, 8.0) }).unwrap().events,
    );
    // leading and trailing edges differ; reversing the scan swaps which physical edge leads, so
    // each edge of the dot changes polarity
    assert_ne!(fwd.0, fwd.1);
    assert_ne!(rev.0, rev.1);
    assert_eq!(fwd.0, rev.0);
}

#[test]
fn check4_blob_width_and_every_letter_readable() {
    let (dot, sensor) = (text("A", 3), quiet());
    let width = |d| checks::blob_width_px(&simulate(&dot, &sensor, &steady(d, 8.0)).unwrap(), 10, 640);
    let w02 = width(0.2);
    assert!((22.0..=32.0).contains(&w02), "0.2 mm: {w02} px (paper: about 27)");
    for d in [0.6, 1.0, 1.5] {
        let w = width(d);
        assert!((34.0..=55.0).contains(&w), "{d} mm: {w} px (paper: 34-55)");
    }
    let letters = Board::new(
        BoardKind::Text("ABCDEFGHIJKLM/NOPQRSTUVWXYZ".into()),
        BoardGeometry { cell_spacing_mm: 10.0, ..BoardGeometry::default() },
        5,
    )
    .unwrap();
    for row in 0..2 {
        let s = simulate(&letters, &sensor, &ScanConfig { row, ..steady(1.0, 16.0) }).unwrap();
        for (letter, cell) in checks::recover_cells(&s) {
            assert_eq!(Some(cell), sim::braille::cell_of(letter), "letter {letter}");
        }
    }
}

#[test]
fn check5_noise_floor_without_contact() {
    let sensor = Sensor::new(CameraConfig::default(), GelConfig::default(), 1).unwrap();
    let s = simulate(&text(" ", 1), &sensor, &steady(1.0, 8.0)).unwrap();
    let rate = s.events.len() as f64 / s.truth.timeline.end_s;
    let expected = sensor.camera.noise_rate_hz();
    assert!((rate / expected - 1.0).abs() < 0.03, "{rate:.1} Hz against {expected:.1} Hz");
}

#[test]
fn check6_static_hold_falls_silent() {
    let dot = text("A", 3);
    let stop = ScanConfig { slide_mm: Some(dot.characters[0].x_mm), hold_s: 0.2, ..steady(1.0, 8.0) };
    let s = simulate(&dot, &quiet(), &stop).unwrap();
    let tl = s.truth.timeline;
    let (end, lift) = ((tl.slide_end_s * 1e6) as i64, (tl.lift_start_s * 1e6) as i64);
    let late: Vec<i64> = s.events.iter().filter(|e| e.t_us > end + 6_000 && e.t_us < lift).map(|e| e.t_us).collect();
    assert!(
        late.is_empty(),
        "events {:?} ms after the stop",
        late.iter().map(|t| (t - end) / 1000).collect::<Vec<_>>()
    );
    assert!(
        s.events.iter().any(|e| e.t_us >= end && e.t_us <= end + 6_000),
        "the photoreceptor settles with a few events"
    );
}

#[test]
fn check7_readout_grid_and_refractory() {
    let sensor = Sensor::new(CameraConfig::default(), GelConfig::default(), 1).unwrap();
    let s =
        simulate(&text("GH", 6), &sensor, &ScanConfig { speed_mm_s: 32.0, seed: 9, ..ScanConfig::default() }).unwrap();
    let (gap, on_grid) = checks::readout(&s, 200);
    assert!(on_grid);
    assert!(gap >= sensor.camera.refractory_us, "{gap} us");
    assert!(s.events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
}

#[test]
fn check8_same_seed_same_stream_bit_for_bit() {
    let sensor = Sensor::new(CameraConfig::default(), GelConfig::default(), 1).unwrap();
    let board = text("HI", 6);
    let scan = ScanConfig { speed_mm_s: 32.0, seed: 11, ..ScanConfig::default() };
    let a = simulate(&board, &sensor, &scan).unwrap();
    let b = simulate(&board, &sensor, &scan).unwrap();
    assert_eq!(a.events, b.events);
    assert_eq!(a.truth, b.truth);
    let c = simulate(&board, &sensor, &ScanConfig { seed: 12, ..scan }).unwrap();
    assert_ne!(a.events, c.events);
}

#[test]
fn truth_times_match_the_motion() {
    let board = text("AB", 1);
    let s = simulate(&board, &quiet(), &steady(1.0, 16.0)).unwrap();
    let tr = &s.truth;
    let a = &tr.characters[0];
    let t = a.columns[0].t_center_s.unwrap();
    // sensor centre starts at 0 mm, reaches the column after x / v seconds of sliding
    let expected = tr.timeline.slide_start_s + a.columns[0].x_mm / 16.0;
    assert!((t - expected).abs() < 1e-9);
    let enter = a.columns[0].t_enter_s.unwrap();
    assert!((t - enter - tr.fov_width_mm / 2.0 / 16.0).abs() < 1e-9);
    assert_eq!(tr.characters.iter().map(|c| c.letter).collect::<String>(), "AB");
}

#[test]
fn trials_in_parallel_equal_trials_one_by_one() {
    use rayon::prelude::*;
    let sensor = Sensor::new(
        CameraConfig { resolution: encoders::Resolution::new(160, 120), ..CameraConfig::default() },
        GelConfig::default(),
        2,
    )
    .unwrap();
    let board = text("AB", 7);
    let scan = |seed: u64| {
        simulate(&board, &sensor, &ScanConfig { speed_mm_s: 32.0, seed, ..ScanConfig::default() }).unwrap().events
    };
    let sequential: Vec<_> = (0..6).map(scan).collect();
    let parallel: Vec<_> = (0..6u64).into_par_iter().map(scan).collect();
    assert_eq!(sequential, parallel);
}
