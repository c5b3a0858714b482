//! Robustness carried to words (SIMULATED): each architecture's whole reader (segmentation,
//! classifier, temporal filter, speed estimated from the events) reads a board's words as one
//! nuisance grows and the rest stay at a base preset, scored unconditionally (1 - WER, inserted
//! words count) without spelling and with the lexicon; a reader's cliff is the first level,
//! from gentle to harsh, where its words with the lexicon fall under [`CLIFF`]. Every level gets
//! its own scans, each read by every reader.

use crate::Progress;
use crate::error::{Error, Result};
use crate::eval::robustness::{Nuisance, Report, SweepSpec};
use crate::eval::words::{WordsSpec, read_scans_in, score};
use pipeline::classify::ReaderModels;
use pipeline::reader::{Spell, TimingMode};
use serde::Serialize;
use std::fmt::Write as _;

/// Word accuracy (1 - WER, with the lexicon) a reader must hold: under it, it has fallen.
pub const CLIFF: f64 = 0.9;

/// One nuisance's words: 1 - WER per reader per level, without spelling and with the lexicon.
#[derive(Debug, Clone, Serialize)]
pub struct WordsCurve {
    pub nuisance: Nuisance,
    pub label: &'static str,
    pub levels: Vec<f64>,
    /// `[reader][level]`.
    pub words_none: Vec<Vec<f64>>,
    pub words_lexicon: Vec<Vec<f64>>,
    /// The median relative error of the estimated speed, `[reader][level]`.
    pub speed_error_median: Vec<Vec<f64>>,
    /// Per reader, the levels where its words with the lexicon fall under [`CLIFF`], and its
    /// cliff: the first of them on a nuisance whose levels run from gentle to harsh (`None`: it
    /// holds at every level, or the levels have no such order).
    pub under: Vec<Vec<f64>>,
    pub cliff: Vec<Option<f64>>,
}

/// The readers' words over every nuisance swept (`models` names the readers).
pub type WordsReport = Report<WordsCurve>;

/// The levels of `levels` where `accuracy` falls under [`CLIFF`], and the first of them when the
/// levels run from gentle to harsh.
pub fn cliff(levels: &[f64], accuracy: &[f64], monotone: bool) -> (Vec<f64>, Option<f64>) {
    let under: Vec<f64> = levels.iter().zip(accuracy).filter(|(_, a)| **a < CLIFF).map(|(l, _)| *l).collect();
    let first = if monotone { under.first().copied() } else { None };
    (under, first)
}

/// Sweeps each nuisance of `spec` with the named readers, speed estimated from the events.
pub fn sweep_words(
    spec: &SweepSpec,
    readers: &[(String, &ReaderModels)],
    progress: &dyn Progress,
) -> Result<WordsReport> {
    if readers.is_empty() {
        return Err(Error::Setting { name: "readers", value: "none".into(), expected: "at least one reader to sweep" });
    }
    let models: Vec<&ReaderModels> = readers.iter().map(|(_, r)| *r).collect();
    let mut curves = Vec::new();
    for &nuisance in &spec.nuisances {
        let levels = nuisance.word_levels();
        let n = readers.len();
        let mut curve = WordsCurve {
            nuisance,
            label: nuisance.label(),
            levels: levels.clone(),
            words_none: vec![Vec::new(); n],
            words_lexicon: vec![Vec::new(); n],
            speed_error_median: vec![Vec::new(); n],
            under: Vec::new(),
            cliff: Vec::new(),
        };
        for &level in &levels {
            let mut setup = spec.base.setup();
            let mut words = WordsSpec {
                board: spec.board.clone(),
                speed_mm_s: spec.speed_mm_s,
                speed_variation: 0.0,
                depth_mm: spec.depth_mm,
                trials: spec.trials,
                seed: spec.seed,
                world: spec.world.clone(),
            };
            nuisance.apply(&mut setup, &mut words.speed_mm_s, &mut words.world, level);
            let lines = read_scans_in(&words, &setup, &models, &[TimingMode::Estimated], progress)?;
            for (k, r) in models.iter().enumerate() {
                let s = score(r.classifier.arch(), TimingMode::Estimated, k, &lines, words.condition());
                let of =
                    |spell: Spell| s.by_spell.iter().find(|b| b.spell == spell).map_or(f64::NAN, |b| b.word_accuracy);
                curve.words_none[k].push(of(Spell::None));
                curve.words_lexicon[k].push(of(Spell::Lexicon));
                curve.speed_error_median[k].push(s.speed_error.median);
            }
            progress.note(&format!(
                "SIMULATED words, {nuisance:?} = {level}: {}",
                readers
                    .iter()
                    .zip(&curve.words_lexicon)
                    .map(|((name, _), a)| format!("{name} {:.3}", a.last().unwrap_or(&f64::NAN)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        for k in 0..n {
            let (under, first) = cliff(&levels, &curve.words_lexicon[k], nuisance.monotone());
            curve.under.push(under);
            curve.cliff.push(first);
        }
        curves.push(curve);
    }
    Ok(WordsReport {
        data: "SIMULATED (virtual Evetac)",
        spec: spec.clone(),
        models: readers.iter().map(|(n, _)| n.clone()).collect(),
        curves,
    })
}

/// The curves as Markdown: per nuisance, 1 - WER per level (none / lexicon) and each reader's
/// cliff, after a summary of every cliff.
pub fn markdown_words(r: &WordsReport, command: &str) -> String {
    let mut m = String::new();
    let s = &r.spec;
    let _ = writeln!(
        m,
        "# Robustness of word reading (SIMULATED)\n\nEach architecture's reader (from `{}`: segmentation, classifier, temporal filter, the speed estimated from the events, each with the noise filter its models were trained behind) reads board {} as one nuisance grows, the rest at the `{}` preset; {} mm/s and {} mm unless swept, {} scans per row and level (seed {}), sensor builds {:?} unless swept. Each cell: 1 - WER over every printed word (inserted words count; below zero, more inserted than printed) without spelling / with the lexicon. A reader's cliff is the first level, from gentle to harsh, where its words with the lexicon fall under {CLIFF}. Made by `{command}`.\n",
        s.models_dir,
        corpus::boards::board_name(&s.board),
        s.base,
        s.speed_mm_s,
        s.depth_mm,
        s.trials,
        s.seed,
        s.world.sensors,
    );
    let _ = writeln!(m, "## Cliffs\n");
    let _ = write!(m, "| nuisance |");
    for name in &r.models {
        let _ = write!(m, " {name} |");
    }
    let _ = writeln!(m, "\n|{}", " --- |".repeat(1 + r.models.len()));
    for c in &r.curves {
        let _ = write!(m, "| {} |", c.label);
        for k in 0..r.models.len() {
            let cell = match (c.cliff[k], c.under[k].is_empty()) {
                (_, true) => format!("holds to {}", c.levels.last().copied().unwrap_or(f64::NAN)),
                (Some(level), false) => format!("falls at {level}"),
                (None, false) => format!("under {CLIFF} at {:?}", c.under[k]),
            };
            let _ = write!(m, " {cell} |");
        }
        let _ = writeln!(m);
    }
    let _ = writeln!(m);
    for c in &r.curves {
        let _ = writeln!(m, "## {}\n", c.label);
        let _ = write!(m, "| level |");
        for name in &r.models {
            let _ = write!(m, " {name}: none / lexicon | speed error |");
        }
        let _ = writeln!(m, "\n|{}", " --- |".repeat(1 + 2 * r.models.len()));
        for (i, level) in c.levels.iter().enumerate() {
            let _ = write!(m, "| {level} |");
            for k in 0..r.models.len() {
                let _ = write!(
                    m,
                    " {:.3} / {:.3} | {:+.1}% |",
                    c.words_none[k][i],
                    c.words_lexicon[k][i],
                    100.0 * c.speed_error_median[k][i]
                );
            }
            let _ = writeln!(m);
        }
        let _ = writeln!(m);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cliff_is_the_first_level_under_the_bar_where_levels_have_an_order() {
        let levels = [0.1, 0.3, 1.0, 3.0];
        assert_eq!(cliff(&levels, &[1.0, 0.95, 0.5, 0.92], true), (vec![1.0], Some(1.0)));
        assert_eq!(cliff(&levels, &[1.0, 0.9, 0.9, 0.9], true), (vec![], None));
        // a reader that recovers past a fall still fell at the first
        assert_eq!(cliff(&levels, &[0.2, 0.95, 0.95, 0.1], true), (vec![0.1, 3.0], Some(0.1)));
        // the field of view falls on both sides of the design's: no cliff, the levels named
        assert_eq!(cliff(&[16.7, 18.6, 20.5], &[0.5, 1.0, 0.8], false), (vec![16.7, 20.5], None));
        // a reader that inserts more words than printed is under the bar
        assert_eq!(cliff(&[8.0], &[-0.3], true).1, Some(8.0));
    }
}
