//! Where a reader abstains (issue #113): the least lexicon score per letter of a word it gives out
//! ([`pipeline::abstain`]), chosen on validation data by the rule in docs/protocol.md
//! ("Abstention: the rule"), for the operating point already recorded in the segmentation
//! network's model file (`braille calibrate-reader --abstain`).
//!
//! The reader reads the validation boards once with abstention off. Abstaining changes nothing
//! in the reading but which words count as text (an unreadable word is still given out, marked),
//! so every threshold is scored on the same readings: each word's score is computed once, and a
//! threshold marks the words under it unreadable before [`score`] counts them (a printed word
//! under an unreadable mark counts as missed).

use crate::eval::words::{WordsSpec, read_scans_in, score};
use crate::{Progress, Result};
use corpus::world::{SensorBuilds, VALIDATION_SEED, World};
use pipeline::classify::ReaderModels;
use pipeline::reader::{Spell, TimingMode};
use serde::Serialize;
use sim::{BoardKind, Realism};
use snn::model_file::Arch;
use std::fmt::Write as _;

/// The rule, as docs/protocol.md writes it and the model file records it.
pub const RULE: &str = "the threshold with the highest mean 1 - WER with the lexicon over the harsh cells, among those whose mean over the nominal cells is at most 0.002 below reading without abstention; ties to the lower threshold (the reader that abstains least), and none unless a threshold is higher";

/// Which scans and which thresholds.
#[derive(Debug, Clone, Serialize)]
pub struct AbstainSpec {
    pub boards: Vec<BoardKind>,
    pub presets: Vec<Realism>,
    pub speeds_mm_s: Vec<f64>,
    pub depths_mm: Vec<f64>,
    /// Scans per board row at each condition.
    pub trials: u64,
    /// The least lexicon scores per letter tried (natural log).
    pub thresholds: Vec<f64>,
}

impl AbstainSpec {
    /// The rule's data: the validation words and the validation sentences in letters
    /// (`VAL-WORDS`, `VAL-SENTENCES`), validation builds and seed, at `nominal` and `harsh` x 8-200
    /// mm/s x 0.6-1.5 mm, one scan a row.
    pub fn validation(thresholds: Vec<f64>) -> AbstainSpec {
        AbstainSpec {
            boards: vec![
                corpus::boards::validation_words_board(),
                corpus::boards::validation_sentences_letters_board(),
            ],
            presets: vec![Realism::Nominal, Realism::Harsh],
            speeds_mm_s: vec![8.0, 16.0, 32.0, 64.0, 128.0, 200.0],
            depths_mm: vec![0.6, 1.0, 1.5],
            trials: 1,
            thresholds,
        }
    }
}

/// One threshold (`None`: no abstention): its 1 - WER with the lexicon and without spelling,
/// cell by cell (in the order of [`AbstainCalibration::cells`]), and the means the rule reads.
#[derive(Debug, Clone, Serialize)]
pub struct AbstainRow {
    pub min_score_per_char: Option<f64>,
    pub lexicon: Vec<f64>,
    pub none: Vec<f64>,
    pub mean_nominal_lexicon: f64,
    pub mean_harsh_lexicon: f64,
    pub mean_nominal_none: f64,
    pub mean_harsh_none: f64,
    /// Words marked unreadable, of all words given out.
    pub unreadable: usize,
    pub words: usize,
}

/// A condition of the validation data.
#[derive(Debug, Clone, Serialize)]
pub struct AbstainCell {
    pub board: String,
    pub realism: Realism,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct AbstainCalibration {
    pub data: &'static str,
    pub arch: Arch,
    pub segmenter: String,
    pub classifier: String,
    pub spec: AbstainSpec,
    pub sensor_builds: Vec<u64>,
    pub seed: u64,
    pub cells: Vec<AbstainCell>,
    pub rows: Vec<AbstainRow>,
    pub rule: &'static str,
    /// The row chosen.
    pub chosen: usize,
}

impl AbstainCalibration {
    pub fn chosen_threshold(&self) -> Option<f64> {
        self.rows[self.chosen].min_score_per_char
    }
}

/// The rule over the rows (row 0 is no abstention): see [`RULE`].
pub fn choose(rows: &[AbstainRow]) -> usize {
    let floor = rows[0].mean_nominal_lexicon - 0.002;
    let mut best = 0;
    for (i, r) in rows.iter().enumerate().skip(1) {
        let (b, t) = (&rows[best], r.min_score_per_char.unwrap_or(f64::NEG_INFINITY));
        let lower = t < b.min_score_per_char.unwrap_or(f64::INFINITY);
        let better = r.mean_harsh_lexicon > b.mean_harsh_lexicon
            || (r.mean_harsh_lexicon == b.mean_harsh_lexicon && lower && best != 0);
        if r.mean_nominal_lexicon >= floor && better {
            best = i;
        }
    }
    best
}

/// Reads `spec`'s validation scans once with `reader` (its abstention off) and scores every
/// threshold.
pub fn calibrate_abstention(
    reader: &ReaderModels,
    arch: Arch,
    (segmenter, classifier): (&str, &str),
    spec: &AbstainSpec,
    progress: &dyn Progress,
) -> Result<AbstainCalibration> {
    let thresholds: Vec<Option<f64>> = std::iter::once(None).chain(spec.thresholds.iter().copied().map(Some)).collect();
    let mut rows: Vec<AbstainRow> = thresholds
        .iter()
        .map(|&t| AbstainRow {
            min_score_per_char: t,
            lexicon: Vec::new(),
            none: Vec::new(),
            mean_nominal_lexicon: 0.0,
            mean_harsh_lexicon: 0.0,
            mean_nominal_none: 0.0,
            mean_harsh_none: 0.0,
            unreadable: 0,
            words: 0,
        })
        .collect();
    let mut cells = Vec::new();
    let mut sensor_builds = Vec::new();
    for &realism in &spec.presets {
        let world = World::of(realism, SensorBuilds::Validation);
        sensor_builds.clone_from(&world.sensors);
        let setup = world.setup();
        for board in &spec.boards {
            for &depth_mm in &spec.depths_mm {
                for &speed_mm_s in &spec.speeds_mm_s {
                    let words = WordsSpec {
                        board: board.clone(),
                        speed_mm_s,
                        speed_variation: 0.0,
                        depth_mm,
                        trials: spec.trials,
                        seed: VALIDATION_SEED,
                        world: world.clone(),
                    };
                    // one reader: `lines[scan][0]`, marked in place for each threshold in turn
                    let mut lines = read_scans_in(&words, &setup, &[reader], &[TimingMode::Estimated], progress)?;
                    for w in lines.iter_mut().flat_map(|scan| &mut scan[0].words) {
                        w.lexicon_score_per_char = pipeline::abstain::score_per_char(&w.chars);
                    }
                    for (row, &t) in rows.iter_mut().zip(&thresholds) {
                        for w in lines.iter_mut().flat_map(|scan| &mut scan[0].words) {
                            w.unreadable = matches!((t, w.lexicon_score_per_char), (Some(t), Some(s)) if s < t);
                        }
                        row.words += lines.iter().map(|s| s[0].words.len()).sum::<usize>();
                        row.unreadable += lines.iter().flat_map(|s| &s[0].words).filter(|w| w.unreadable).count();
                        let s = score(arch, TimingMode::Estimated, 0, &lines, words.condition());
                        let of = |spell: Spell| {
                            s.by_spell.iter().find(|b| b.spell == spell).map_or(f64::NAN, |b| b.word_accuracy)
                        };
                        row.lexicon.push(of(Spell::Lexicon));
                        row.none.push(of(Spell::None));
                    }
                    let board = corpus::boards::board_name(board);
                    progress.note(&format!(
                        "SIMULATED {board} {realism} {speed_mm_s} mm/s {depth_mm} mm {arch}: lexicon {:.3} without abstention",
                        rows[0].lexicon.last().copied().unwrap_or(f64::NAN)
                    ));
                    cells.push(AbstainCell { board, realism, speed_mm_s, depth_mm });
                }
            }
        }
    }
    for r in &mut rows {
        let mean = |v: &[f64], realism: Realism| {
            let x: Vec<f64> = v.iter().zip(&cells).filter(|(_, c)| c.realism == realism).map(|(a, _)| *a).collect();
            x.iter().sum::<f64>() / x.len().max(1) as f64
        };
        r.mean_nominal_lexicon = mean(&r.lexicon, Realism::Nominal);
        r.mean_harsh_lexicon = mean(&r.lexicon, Realism::Harsh);
        r.mean_nominal_none = mean(&r.none, Realism::Nominal);
        r.mean_harsh_none = mean(&r.none, Realism::Harsh);
    }
    let chosen = choose(&rows);
    Ok(AbstainCalibration {
        data: "SIMULATED (virtual Evetac)",
        arch,
        segmenter: segmenter.to_string(),
        classifier: classifier.to_string(),
        spec: spec.clone(),
        sensor_builds,
        seed: VALIDATION_SEED,
        cells,
        rows,
        rule: RULE,
        chosen,
    })
}

/// The thresholds as a table: each row's means and its unreadable words.
pub fn markdown(c: &AbstainCalibration) -> String {
    let mut m = String::new();
    let boards: Vec<String> = c.spec.boards.iter().map(corpus::boards::board_name).collect();
    let _ = writeln!(
        m,
        "# Where the {} reader abstains (SIMULATED, validation)\n\n{} with {} reads {} by validation builds {:?} (seed {}), {} scan(s) a row, at {:?} x {:?} mm/s x {:?} mm, speed estimated, once; each threshold marks the words whose lexicon score per letter is under it unreadable, and a printed word under a mark counts as missed. 1 - WER (inserted words count). Rule: {}. Made by `braille calibrate-reader --abstain --arch {}`.\n",
        c.arch,
        c.segmenter,
        c.classifier,
        boards.join(" and "),
        c.sensor_builds,
        c.seed,
        c.spec.trials,
        c.spec.presets.iter().map(|p| p.to_string()).collect::<Vec<_>>(),
        c.spec.speeds_mm_s,
        c.spec.depths_mm,
        c.rule,
        c.arch
    );
    let _ = writeln!(
        m,
        "| least lexicon score per letter | harsh, lexicon | harsh, none | nominal, lexicon | nominal, none | unreadable words |\n| --- | --- | --- | --- | --- | --- |"
    );
    for (i, r) in c.rows.iter().enumerate() {
        let t = r.min_score_per_char.map_or("none (no abstention)".to_string(), |t| format!("{t}"));
        let mark = if i == c.chosen { " **chosen**" } else { "" };
        let _ = writeln!(
            m,
            "| {t}{mark} | {:.3} | {:.3} | {:.3} | {:.3} | {} of {} |",
            r.mean_harsh_lexicon, r.mean_harsh_none, r.mean_nominal_lexicon, r.mean_nominal_none, r.unreadable, r.words
        );
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: Option<f64>, nominal: f64, harsh: f64) -> AbstainRow {
        AbstainRow {
            min_score_per_char: t,
            lexicon: Vec::new(),
            none: Vec::new(),
            mean_nominal_lexicon: nominal,
            mean_harsh_lexicon: harsh,
            mean_nominal_none: nominal,
            mean_harsh_none: harsh,
            unreadable: 0,
            words: 0,
        }
    }

    #[test]
    fn the_rule_guards_nominal_and_prefers_abstaining_least() {
        // -2 gains most at harsh but costs nominal 0.003: out; -3 and -4 tie: the lower, -4
        let rows = [
            row(None, 0.990, 0.30),
            row(Some(-2.0), 0.987, 0.60),
            row(Some(-3.0), 0.989, 0.50),
            row(Some(-4.0), 0.990, 0.50),
            row(Some(-5.0), 0.990, 0.40),
        ];
        assert_eq!(choose(&rows), 3);
        // nothing gains: no abstention
        assert_eq!(choose(&[row(None, 1.0, 0.5), row(Some(-3.0), 1.0, 0.5), row(Some(-4.0), 1.0, 0.4)]), 0);
    }
}
