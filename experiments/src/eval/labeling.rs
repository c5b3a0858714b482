//! The paper's labeling pipeline scored against the simulator's ground truth (SIMULATED data):
//! `braille label-check`.

use pipeline::labeling::{LabelerConfig, Labeling};
use serde::Serialize;

/// How the labeler did against the simulator's ground truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LabelingScore {
    pub expected: usize,
    pub found: usize,
    /// Windows whose character is the one the truth puts there.
    pub correct: usize,
    /// `correct / expected`.
    pub accuracy: f64,
}

/// The time (s) at which a board position `x_mm` crosses pooled column `col` of the image, given
/// the time `t_center_s` it crosses the image centre (forward scan: content moves to lower x).
fn time_at_column(t_center_s: f64, col: f64, pool: u16, truth: &sim::ScanTruth) -> f64 {
    let x_px = col * pool as f64;
    let dx_mm = (x_px - truth.resolution.width as f64 / 2.0) * truth.pitch_mm;
    let sign = match truth.scan.direction {
        sim::Direction::Forward => 1.0,
        sim::Direction::Reverse => -1.0,
    };
    t_center_s - sign * dx_mm / truth.scan.speed_mm_s
}

/// Scores windows against the truth: the `i`-th window must belong to the `i`-th printed
/// character, meaning its `t_max` lies within half a dot-column lag of the time that character's
/// last column crosses the start window.
pub fn score(labeling: &Labeling, truth: &sim::ScanTruth, cfg: &LabelerConfig) -> LabelingScore {
    let chars: Vec<&sim::scan::CharacterTruth> = truth.characters.iter().filter(|c| !c.columns.is_empty()).collect();
    let window_col = (cfg.start_window_cols.start + cfg.start_window_cols.end) as f64 / 2.0;
    let tolerance_s = 0.5 * 2.5 / truth.scan.speed_mm_s;
    let mut correct = 0;
    for (w, c) in labeling.windows.iter().zip(&chars) {
        let Some(t_center) = c.columns.last().and_then(|col| col.t_center_s) else { continue };
        let onset = time_at_column(t_center, window_col, cfg.pool, truth);
        if ((w.t_max_us as f64) * 1e-6 - onset).abs() <= tolerance_s {
            correct += 1;
        }
    }
    LabelingScore {
        expected: chars.len(),
        found: labeling.windows.len(),
        correct,
        accuracy: if chars.is_empty() { 1.0 } else { correct as f64 / chars.len() as f64 },
    }
}

/// One condition of the label check.
#[derive(Debug, Clone, Serialize)]
pub struct LabelCheckRow {
    pub board: String,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub scans: usize,
    /// Characters printed, and windows that belong to the character the truth puts there.
    pub characters: usize,
    pub correct: usize,
    pub accuracy: f64,
    /// Scans whose window count was the row's character count.
    pub count_matched: usize,
}

/// The boards a label check scans.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum CheckBoards {
    /// The test boards: RAB over depth and speed, EV over speed (the scans the tests score).
    #[default]
    Test,
    /// The validation boards in their place: VAL over depth and speed, VAL-WORDS over speed.
    /// Where the labeler's settings are chosen (with the training sensor builds and the
    /// validation seed).
    Validation,
}

/// The labeling pipeline against the ground truth, `trials` scans per row: the paper's training
/// boards at its training condition, the alphabet board of `boards` over depth and speed, and its
/// word board over speed. The scans are `world`'s, seeded as its test sets are (with the tests'
/// seed and trials, the very scans Table I and the depth curve score).
pub fn label_check(
    trials: u64,
    seed: u64,
    world: &corpus::world::World,
    boards: CheckBoards,
) -> crate::Result<Vec<LabelCheckRow>> {
    use rayon::prelude::*;
    use sim::BoardKind;
    let setup = world.setup();
    let sensors = world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    let cfg = LabelerConfig::default();
    let (alphabet, words) = match boards {
        CheckBoards::Test => (BoardKind::Rab, BoardKind::Ev),
        CheckBoards::Validation => (BoardKind::Val, corpus::boards::validation_words_board()),
    };
    let mut conditions: Vec<(BoardKind, f64, f64)> = vec![(BoardKind::Sab, 8.0, 1.5), (BoardKind::Un, 8.0, 1.5)];
    conditions.extend([0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5].map(|d| (alphabet.clone(), 8.0, d)));
    conditions.extend([16.0, 24.0, 32.0].map(|v| (alphabet.clone(), v, 1.5)));
    conditions.extend([8.0, 16.0, 24.0, 32.0].map(|v| (words.clone(), v, 1.5)));
    conditions
        .par_iter()
        .map(|(kind, speed, depth)| {
            let board = world.board(&setup, kind)?;
            let (mut chars, mut correct, mut matched, mut scans) = (0, 0, 0, 0);
            for row in 0..board.rows.len() {
                for trial in 0..trials {
                    let scan_seed = world.scan_seed(seed, kind, row, trial, *speed, *depth);
                    let scan = setup.scan(*speed, *depth, row, scan_seed);
                    let sensor = &sensors[(trial % sensors.len() as u64) as usize];
                    let s = sim::simulate(&board, sensor, &scan)?;
                    // the true count labels; the score says whether the labeler found it
                    let n = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).count();
                    let l = pipeline::labeling::label(&s.events, sensor.camera.resolution, *speed, n, &cfg)?;
                    let sc = score(&l, &s.truth, &cfg);
                    chars += sc.expected;
                    correct += sc.correct;
                    matched += l.count_matched as usize;
                    scans += 1;
                }
            }
            Ok(LabelCheckRow {
                board: if boards == CheckBoards::Validation && *kind == words {
                    "VAL-WORDS".into()
                } else {
                    kind.name()
                },
                speed_mm_s: *speed,
                depth_mm: *depth,
                scans,
                characters: chars,
                correct,
                accuracy: correct as f64 / chars.max(1) as f64,
                count_matched: matched,
            })
        })
        .collect()
}

/// The label check as a Markdown table.
pub fn label_check_markdown(rows: &[LabelCheckRow]) -> String {
    use std::fmt::Write as _;
    let mut m = String::from("Labeling pipeline against ground truth (SIMULATED scans, virtual Evetac):\n\n");
    m.push_str("| board | speed (mm/s) | depth (mm) | scans | count matched | windows right |\n| --- | --- | --- | --- | --- | --- |\n");
    for r in rows {
        let _ = writeln!(
            m,
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
    m
}
