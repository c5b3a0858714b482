//! The checks of SIMULATOR.md on fresh simulated scans at the `clean` and `nominal` presets
//! (physics only; no classifier), and the nuisances of the `nominal` preset.

use sim::checks::{self, SPEEDS_MM_S};
use sim::{Board, BoardGeometry, BoardKind, CameraConfig, GelConfig, Realism, ScanConfig, Sensor, simulate};

fn quiet() -> Sensor {
    Sensor::new(CameraConfig::default().without_noise(), GelConfig::default(), 1).unwrap()
}

fn text(t: &str, seed: u64) -> Board {
    Board::new(BoardKind::Text(t.into()), BoardGeometry::default(), seed).unwrap()
}

fn steady(depth_mm: f64, speed_mm_s: f64) -> ScanConfig {
    ScanConfig { depth_mm, speed_mm_s, speed_ripple: 0.0, misalignment_sigma_mm: 0.0, seed: 1, ..ScanConfig::default() }
}

/// The checks of SIMULATOR.md and the gel's own (lag and smear, press and release, spread across
/// sensor builds), each held to its bounds by `CheckReport::failures`.
fn checks_pass(realism: Realism) {
    let report = checks::run(realism, 2).unwrap();
    let failures = report.failures();
    assert!(failures.is_empty(), "{realism}: {failures:#?}");
}

#[test]
fn the_checks_pass_at_clean() {
    checks_pass(Realism::Clean);
}

#[test]
fn the_checks_pass_at_nominal() {
    checks_pass(Realism::Nominal);
}

#[test]
fn the_gel_smears_a_dot_behind_it_and_lags_on_release() {
    let report = checks::run(Realism::Nominal, 1).unwrap();
    // The recovery spreads a dot's events over more of the board than the bare stamp does, and the
    // lag of the surface on release is a fraction of the relaxing share of the depth.
    for v in SPEEDS_MM_S {
        assert!(report.dot_smear_px[&format!("{v:.0}")] > 0.5, "{:?}", report.dot_smear_px);
    }
    let p = &report.press_release;
    let g = Realism::Nominal.setup().gel.dynamics.relaxing_fraction();
    assert!(p.max_surface_lag_mm > 0.0 && p.max_surface_lag_mm < g * p.depth_mm, "{}", p.max_surface_lag_mm);
    // Pressing follows the indenter; the force on release is below the force on loading.
    let (load, unload) = (&p.loading, &p.unloading);
    let mid = load.len() / 2;
    let back = unload.iter().min_by(|a, b| (a.0 - load[mid].0).abs().total_cmp(&(b.0 - load[mid].0).abs())).unwrap();
    assert!(back.1 < load[mid].1, "release {back:?} against press {:?}", load[mid]);
}

#[test]
fn nuisances_are_drawn_per_trial_and_clean_scans_keep_their_events() {
    let setup = Realism::Nominal.setup();
    let board = Board::new(BoardKind::Text("AB".into()), setup.geometry.clone(), 1).unwrap();
    let sensor = setup.sensor(encoders::Resolution::new(160, 120), 3).unwrap();
    let a = simulate(&board, &sensor, &setup.scan(16.0, 1.0, 0, 1)).unwrap();
    let b = simulate(&board, &sensor, &setup.scan(16.0, 1.0, 0, 2)).unwrap();
    assert_ne!(a.truth.yaw_deg, b.truth.yaw_deg);
    assert_ne!(a.truth.depth_profile_mm, b.truth.depth_profile_mm);
    assert_eq!(a.truth.depth_profile_mm.len(), 3);
    assert!(a.truth.depth_profile_mm.iter().all(|d| (d - 1.0).abs() < 0.3), "{:?}", a.truth.depth_profile_mm);
    assert_eq!(a.events, simulate(&board, &sensor, &setup.scan(16.0, 1.0, 0, 1)).unwrap().events);
    // A hand-held slide changes speed along the row but keeps its mean and never stops. (Without
    // the mount's stick-slip: the truth's speed is the arm's, and a slipping camera jumps about
    // it by up to a jump, 0.1 mm at `nominal`; the mount's own tests check those.)
    let hand = ScanConfig { speed_variation: 0.4, stick_slip: None, ..setup.scan(16.0, 1.0, 0, 1) };
    let h = simulate(&board, &sensor, &hand).unwrap();
    let slide = h.truth.timeline.slide_end_s - h.truth.timeline.slide_start_s;
    assert!((slide * 16.0 / 195.0 - 1.0).abs() < 0.2, "{slide} s for 195 mm at 16 mm/s on average");
    assert!(h.events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
    // The truth's speed is the motion's: integrated between two dot columns' passages it gives
    // their distance, and it swings by about the variation asked for.
    let words = Board::new(BoardKind::Text("HELP WATER".into()), setup.geometry.clone(), 1).unwrap();
    let h = simulate(&words, &sensor, &hand).unwrap();
    let slide = h.truth.timeline.slide_end_s - h.truth.timeline.slide_start_s;
    let cols: Vec<(f64, f64)> = h
        .truth
        .characters
        .iter()
        .flat_map(|c| c.columns.iter().filter_map(|k| k.t_center_s.map(|t| (t, k.x_mm))))
        .collect();
    assert!(cols.len() > 10, "{} columns", cols.len());
    for w in cols.windows(2) {
        let ((t0, x0), (t1, x1)) = (w[0], w[1]);
        let n = 200;
        let travel: f64 =
            (0..n).map(|i| h.truth.speed_at_mm_s(t0 + (i as f64 + 0.5) * (t1 - t0) / n as f64)).sum::<f64>()
                * (t1 - t0)
                / n as f64;
        assert!((travel - (x1 - x0).abs()).abs() < 0.01, "{travel} mm against {} mm", (x1 - x0).abs());
    }
    let tl = &h.truth.timeline;
    let speeds: Vec<f64> =
        (1..100).map(|i| h.truth.speed_at_mm_s(tl.slide_start_s + i as f64 * slide / 100.0)).collect();
    let (lo, hi) = speeds.iter().fold((f64::MAX, 0f64), |(l, u), &v| (l.min(v), u.max(v)));
    assert!(lo > 0.0 && lo < 16.0 * 0.85 && hi > 16.0 * 1.15, "{lo}-{hi} mm/s");
    assert_eq!(h.truth.speed_at_mm_s(tl.slide_end_s + 0.01), 0.0);
}

#[test]
fn the_readout_stretches_frames_under_overload_and_drops_nothing() {
    // A readout limited to 1 M events/s against a busy scan: frames stretch, so events arrive
    // later than on the free grid, and none is lost.
    let setup = Realism::Nominal.setup();
    let board = Board::new(BoardKind::Text("HELP".into()), setup.geometry.clone(), 1).unwrap();
    let free = setup.sensor(encoders::Resolution::new(320, 240), 3).unwrap();
    let mut slow = free.clone();
    slow.camera.event_rate_limit_hz = Some(2e5);
    let scan = setup.scan(32.0, 1.5, 0, 4);
    let (a, b) = (simulate(&board, &free, &scan).unwrap(), simulate(&board, &slow, &scan).unwrap());
    assert_eq!(a.events.len(), b.events.len());
    let late = a.events.iter().zip(&b.events).filter(|(x, y)| y.t_us > x.t_us).count();
    assert!(late > a.events.len() / 10, "{late} of {} late", a.events.len());
    assert!(b.events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
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

#[test]
fn the_print_texture_shows_only_where_the_board_face_presses_the_gel() {
    // A blank row: no dots, noise off, so every event is the texture's.
    let setup = Realism::Nominal.setup();
    let blank = Board::new(BoardKind::Text(" ".into()), setup.geometry.clone(), 1).unwrap();
    let sensor = setup.sensor(encoders::Resolution::new(160, 120), 5).unwrap().without_noise();
    let steady = |depth_mm: f64| ScanConfig {
        depth_wander_sigma_mm: 0.0,
        depth_tilt_sigma_mm_per_100mm: 0.0,
        ..setup.scan(16.0, depth_mm, 0, 1)
    };
    // Above the dot height (0.38 mm) the face does not touch the gel.
    assert!(simulate(&blank, &sensor, &steady(0.3)).unwrap().events.is_empty());
    let deep = simulate(&blank, &sensor, &steady(1.5)).unwrap().events.len();
    assert!(deep > 0, "the face at 1.1 mm into the gel shows its texture");
    // A smooth print shows nothing at any depth.
    let smooth = Board::new(
        BoardKind::Text(" ".into()),
        sim::BoardGeometry { texture_amplitude_mm: 0.0, ..setup.geometry.clone() },
        1,
    )
    .unwrap();
    assert!(simulate(&smooth, &sensor, &steady(1.5)).unwrap().events.is_empty());
}

#[test]
fn stick_slip_delays_the_camera_by_the_mounts_lag_and_repeats_by_seed() {
    // The nominal gel (friction 0.8) pressed 1.5 mm, its face in contact; the light mount.
    let setup = Realism::Nominal.setup();
    let sensor = setup.sensor(encoders::Resolution::new(160, 120), 3).unwrap().without_noise();
    let board = Board::new(BoardKind::Text("AB".into()), setup.geometry.clone(), 1).unwrap();
    let rigid = ScanConfig { speed_ripple: 0.0, ..steady(1.5, 8.0) };
    let slipping = ScanConfig { stick_slip: Some(sim::StickSlip::LIGHT_MOUNT), ..rigid.clone() };
    let (a, b) = (simulate(&board, &sensor, &rigid).unwrap(), simulate(&board, &sensor, &slipping).unwrap());
    assert!(a.truth.stick_slip.is_none());
    let ss = b.truth.stick_slip.as_ref().unwrap();
    assert!(ss.slips > 10, "slips at 8 mm/s, 1.5 mm: {ss:?}");
    assert!(ss.largest_jump_mm > 0.1, "{ss:?}");
    // The camera reaches each column later, by about its lag behind the arm over the speed.
    let late =
        b.truth.characters[1].columns[0].t_center_s.unwrap() - a.truth.characters[1].columns[0].t_center_s.unwrap();
    assert!(late > 0.5 * ss.lag_mid_mm / 8.0 && late < 2.0 * ss.lag_mid_mm / 8.0, "{late} s, lag {ss:?}");
    assert_ne!(a.events, b.events);
    let again = simulate(&board, &sensor, &slipping).unwrap();
    assert_eq!(again.events, b.events);
    assert_eq!(again.truth, b.truth);
}
