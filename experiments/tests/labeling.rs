//! The paper's labeling pipeline on simulated scans, scored against the simulator's truth.

use experiments::labeling::score;
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
        // Dots of the next row can reach the image's bottom edge and the start window (the
        // window spans every row, as in the paper): one miss in nine is possible.
        assert!(sc.correct >= 8, "{speed} mm/s: {sc:?}");
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
