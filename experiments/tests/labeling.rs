//! The paper's labeling pipeline on simulated scans, scored against the simulator's truth.

use corpus::world::{VALIDATION_SEED, World};
use experiments::eval::labeling::score;
use pipeline::labeling::{LabelerConfig, label, window_heatmap};
use sim::{Board, BoardGeometry, BoardKind, CameraConfig, GelConfig, ScanConfig, Sensor, simulate};

#[test]
fn finds_every_character_of_the_alphabet_board_at_both_ends_of_the_speed_range() {
    let sensor = Sensor::new(CameraConfig::default(), GelConfig::default(), 1).unwrap();
    let board = Board::new(BoardKind::Sab, BoardGeometry::default(), Board::default_seed(&BoardKind::Sab)).unwrap();
    let cfg = LabelerConfig::default();
    for speed in [8.0, 32.0] {
        let s = simulate(
            &board,
            &sensor,
            &ScanConfig { speed_mm_s: speed, depth_mm: 1.0, row: 0, seed: 4, ..ScanConfig::default() },
        )
        .unwrap();
        let l = label(&s.events, sensor.camera.resolution, speed, 9, &cfg).unwrap();
        assert!(l.count_matched, "{speed} mm/s: {} windows", l.windows.len());
        let sc = score(&l, &s.truth, &cfg);
        assert_eq!(sc.correct, 9, "{speed} mm/s: {sc:?}");
        // B (dots 1, 2) has one column: its window starts where a second column would be
        let b = &l.windows[1];
        assert_eq!(b.peaks, 1);
        assert_eq!(b.t_start_us - b.t_max_us, (280_000.0 * 8.0 / speed) as i64);
        // B .. I: b has one column too; c has two: its window starts at its second column
        assert_eq!(l.windows[2].t_start_us, l.windows[2].t_max_us);
        let hm = window_heatmap(&s.events, sensor.camera.resolution, speed, &l.windows[2], &cfg).unwrap();
        assert_eq!((hm.bins, hm.height, hm.width), (20, 120, 160));
        assert!(hm.total() > 100.0);
        for b in 0..hm.bins {
            for p in 0..2 {
                for r in 0..hm.height {
                    for c in (0..20).chain(100..160) {
                        assert_eq!(hm.get(b, p, r, c), 0.0, "masked column {c}");
                    }
                }
            }
        }
    }
}

#[test]
fn a_wrong_count_is_reported_not_hidden() {
    let sensor = Sensor::new(CameraConfig::default(), GelConfig::default(), 1).unwrap();
    let board = Board::new(BoardKind::Text("CAT".into()), BoardGeometry::default(), 2).unwrap();
    let s = simulate(&board, &sensor, &ScanConfig { speed_mm_s: 16.0, seed: 1, ..ScanConfig::default() }).unwrap();
    let cfg = LabelerConfig::default();
    // C and T have two columns, A one: at most five peaks, so seven characters cannot be found
    let l = label(&s.events, sensor.camera.resolution, 16.0, 7, &cfg).unwrap();
    assert!(!l.count_matched);
    assert!(l.windows.len() < 7);
}

#[test]
fn the_next_rows_dots_at_the_images_edge_add_no_characters() {
    // The middle row of the validation board at `nominal` (training sensor build 1): the rows
    // above and below press the gel at the image's edges, and a start window over the whole
    // height finds their dot columns as extra peaks; the default's rows leave them out.
    let world = World::train(sim::Realism::Nominal);
    let setup = world.setup();
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, world.sensor_seed(0)).unwrap();
    let board = world.board(&setup, &BoardKind::Val).unwrap();
    let seed = world.scan_seed(VALIDATION_SEED, &BoardKind::Val, 1, 0, 8.0, 1.5);
    let s = simulate(&board, &sensor, &setup.scan(8.0, 1.5, 1, seed)).unwrap();
    let n = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).count();
    let cfg = LabelerConfig::default();
    let l = label(&s.events, sensor.camera.resolution, 8.0, n, &cfg).unwrap();
    assert!(l.count_matched, "{} windows of {n}", l.windows.len());
    assert_eq!(score(&l, &s.truth, &cfg).correct, n);
    let whole = LabelerConfig { start_window_rows: 0..120, ..cfg };
    let l = label(&s.events, sensor.camera.resolution, 8.0, n, &whole).unwrap();
    assert!(!l.count_matched && l.windows.len() > n, "{} windows of {n}", l.windows.len());
}
