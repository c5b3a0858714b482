//! Labelled character windows from simulated scans: what the character classifiers learn from
//! and are tested on. Each scan is labelled by the paper's pipeline ([`crate::labeling`]); a
//! window takes the letter of the character it stands for in reading order, and only scans whose
//! window count matched the row are used (so no window is given another character's letter).

use crate::error::Result;
use crate::labeling::{LabelerConfig, label, window_heatmap};
use encoders::heatmap::Heatmap;
use serde::{Deserialize, Serialize};
use sim::sensor::Sensor;
use sim::{Board, BoardGeometry, BoardKind, ScanConfig};

/// One labelled window.
#[derive(Debug, Clone)]
pub struct CharSample {
    pub letter: char,
    pub map: Heatmap,
    /// Which scan it came from (board, row, trial).
    pub scan: (String, usize, u64),
}

/// Which scans to take windows from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharSetSpec {
    pub boards: Vec<BoardKind>,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub trials: u64,
    pub seed: u64,
}

/// What a build gives: the windows, and the scans skipped because the count did not match.
#[derive(Debug, Clone, Default)]
pub struct CharSet {
    pub samples: Vec<CharSample>,
    pub scans: usize,
    pub skipped_scans: usize,
}

/// The letter index of the 26 classes (`A` = 0).
pub fn class_of(letter: char) -> Option<usize> {
    letter.is_ascii_uppercase().then(|| (letter as u8 - b'A') as usize)
}

/// Windows of one scan: `(board, row, trial)` with scan seed `scan_seed`.
#[allow(clippy::too_many_arguments)]
pub fn scan_windows(
    board: &Board,
    sensor: &Sensor,
    row: usize,
    trial: u64,
    scan_seed: u64,
    speed_mm_s: f64,
    depth_mm: f64,
    cfg: &LabelerConfig,
) -> Result<Option<Vec<CharSample>>> {
    let scan = ScanConfig { speed_mm_s, depth_mm, row, seed: scan_seed, ..ScanConfig::default() };
    let s = sim::simulate(board, sensor, &scan)?;
    let chars: Vec<char> = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).map(|c| c.letter).collect();
    let l = label(&s.events, sensor.camera.resolution, speed_mm_s, chars.len(), cfg)?;
    if !l.count_matched {
        return Ok(None);
    }
    let mut out = Vec::with_capacity(chars.len());
    for (w, &letter) in l.windows.iter().zip(&chars) {
        let map = window_heatmap(&s.events, sensor.camera.resolution, speed_mm_s, w, cfg)?;
        out.push(CharSample { letter, map, scan: (board.kind.name(), row, trial) });
    }
    Ok(Some(out))
}

/// A stable seed per scan.
pub fn scan_seed(seed: u64, board: &BoardKind, row: usize, trial: u64) -> u64 {
    sim::board::stable_hash(&format!("chars/{seed}/{}/{row}/{trial}", board.name()))
}

/// Every (board, row, trial) of `spec`, in a fixed order.
pub fn scans(spec: &CharSetSpec) -> Result<Vec<(Board, usize, u64)>> {
    let mut out = Vec::new();
    for kind in &spec.boards {
        let board = Board::new(kind.clone(), BoardGeometry::default(), Board::default_seed(kind))?;
        for row in 0..board.rows.len() {
            for trial in 0..spec.trials {
                out.push((board.clone(), row, trial));
            }
        }
    }
    Ok(out)
}

/// `rows` board rows of random English words in capitals (uniform over the 3000 most frequent
/// words of TextBlob's list with 2-8 letters, none of them in `exclude`), each at most
/// `max_chars` long, joined by `/` as a text board takes them. Seeded.
pub fn random_word_rows(seed: u64, rows: usize, max_chars: usize, exclude: &[&str]) -> String {
    use rand::{Rng, SeedableRng};
    let words: Vec<String> = crate::spelling::Norvig::textblob()
        .most_frequent(usize::MAX)
        .into_iter()
        .map(|(w, _)| w.to_uppercase())
        .filter(|w| (2..=8).contains(&w.len()) && w.bytes().all(|b| b.is_ascii_uppercase()))
        .filter(|w| !exclude.iter().any(|e| e.eq_ignore_ascii_case(w)))
        .take(3000)
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(rows);
    for _ in 0..rows {
        let mut row = String::new();
        loop {
            let w = &words[rng.random_range(0..words.len())];
            if row.len() + usize::from(!row.is_empty()) + w.len() > max_chars {
                break;
            }
            if !row.is_empty() {
                row.push(' ');
            }
            row.push_str(w);
        }
        out.push(row);
    }
    out.join("/")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn word_rows_are_seeded_bounded_and_leave_out_the_excluded() {
        let a = random_word_rows(7, 5, 22, &["THE", "OF"]);
        assert_eq!(a, random_word_rows(7, 5, 22, &["THE", "OF"]));
        assert_ne!(a, random_word_rows(8, 5, 22, &["THE", "OF"]));
        let rows: Vec<&str> = a.split('/').collect();
        assert_eq!(rows.len(), 5);
        for r in rows {
            assert!(!r.is_empty() && r.len() <= 22, "{r}");
            assert!(r.split(' ').all(|w| w != "THE" && w != "OF" && w.len() >= 2), "{r}");
        }
    }
}
