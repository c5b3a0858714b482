//! Reading words of cells (Unified English Braille): each word's cells back-translated to print
//! through the code's tables, and, beyond the top cells, a beam over the classifier's cell
//! alternatives scored by back-translation and the lexicon. A contraction makes a misread cell a
//! different word rather than a misspelled one (dots 2-3-5 is "!" or, inside a word, "ff";
//! a missed dot turns "the" into "with"), so a speller cannot correct the print letter by letter:
//! it must choose among cell readings.
//!
//! Score of a cell reading `c_1..c_m` (log domain): `sum_i log p_i(c_i) + lm_weight * log P(w)`,
//! where `w` is its back-translation and `P(w)` the product over its words (the runs of letters
//! split at apostrophes and hyphens, case ignored) of their frequencies in the lexicon, `p_oov`
//! for a run the lexicon lacks, `p_number` for a run of digits; punctuation and capitals are
//! free. Readings come from a beam over the `alternatives` most probable cells of each position
//! (cells below `min_prob` of the best are left out), at most `beam` kept at each step.

use crate::code::{BrailleCode, Translator};
use crate::error::Result;
use crate::spelling::Norvig;
use encoders::braille::Cell;
use std::collections::HashMap;

/// The decoder's settings (chosen on the validation sentences, docs/braille.md).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CellSpellConfig {
    pub alternatives: usize,
    pub beam: usize,
    /// A cell whose probability is below this fraction of its position's best is no alternative.
    pub min_prob: f32,
    pub lm_weight: f64,
    /// Prior of a word the lexicon lacks, and of a number.
    pub p_oov: f64,
    pub p_number: f64,
}

impl Default for CellSpellConfig {
    fn default() -> Self {
        CellSpellConfig { alternatives: 3, beam: 16, min_prob: 0.02, lm_weight: 0.5, p_oov: 1e-9, p_number: 1e-5 }
    }
}

/// Reads words of cells in one code; built once, shared by every stream.
pub struct CellSpeller {
    translator: &'static Translator,
    /// Lowercase word -> log frequency.
    lexicon: HashMap<String, f64>,
    cfg: CellSpellConfig,
}

impl CellSpeller {
    /// A speller of `code` over TextBlob's word list (the lexicon of the letter reader).
    pub fn new(code: BrailleCode, cfg: CellSpellConfig) -> Result<CellSpeller> {
        Ok(CellSpeller::with_lexicon(code.translator()?, crate::spelling::TEXTBLOB_WORDS, cfg))
    }

    /// A speller over a list of `word count` lines (`;;;` comments skipped), read as the
    /// letters' corrector reads it ([`Norvig::from_list`]); words of letters only.
    pub fn with_lexicon(translator: &'static Translator, list: &str, cfg: CellSpellConfig) -> CellSpeller {
        let words: Vec<(String, f64)> = Norvig::from_list(list)
            .most_frequent(usize::MAX)
            .into_iter()
            .filter(|(w, _)| w.chars().all(|c| c.is_ascii_alphabetic()))
            .map(|(w, f)| (w.to_ascii_lowercase(), f as f64))
            .collect();
        let total = words.iter().map(|w| w.1).sum::<f64>().max(1.0);
        let mut lexicon = HashMap::with_capacity(words.len());
        for (w, f) in words {
            *lexicon.entry(w).or_insert(0.0) += f / total;
        }
        lexicon.values_mut().for_each(|p| *p = p.ln());
        CellSpeller { translator, lexicon, cfg }
    }

    pub fn code(&self) -> BrailleCode {
        self.translator.code()
    }

    /// The print of cells as read (the top cell of each position).
    pub fn as_read(&self, cells: &[Cell]) -> String {
        self.translator.to_text(cells)
    }

    /// Log prior of a word of print: its letter runs by the lexicon, digit runs as numbers.
    pub fn log_prior(&self, text: &str) -> f64 {
        let mut total = 0.0;
        let mut any = false;
        for run in text.split(|c: char| !c.is_ascii_alphanumeric()).filter(|r| !r.is_empty()) {
            any = true;
            total += if run.bytes().all(|b| b.is_ascii_digit()) {
                self.cfg.p_number.ln()
            } else {
                self.lexicon.get(&run.to_ascii_lowercase()).copied().unwrap_or(self.cfg.p_oov.ln())
            };
        }
        // Print of punctuation alone (or a sequence liblouis gives no meaning, `\456/`) is no word.
        if any { total } else { self.cfg.p_oov.ln() }
    }

    /// The most probable print of a word from each cell's probabilities (`probs[i][k]` of cell
    /// class `k`, dots `k + 1`): the beam's readings back-translated and scored.
    pub fn decode(&self, probs: &[Vec<f32>]) -> String {
        self.decode_scored(probs).map(|r| r.0).unwrap_or_default()
    }

    /// [`decode`](Self::decode) with the reading's score and cells.
    pub fn decode_scored(&self, probs: &[Vec<f32>]) -> Option<(String, f64, Vec<Cell>)> {
        let mut beam: Vec<(Vec<Cell>, f64)> = vec![(Vec::new(), 0.0)];
        for p in probs {
            let mut ranked: Vec<(usize, f32)> = p.iter().copied().enumerate().collect();
            ranked.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            let best = ranked.first().map_or(0.0, |r| r.1);
            let options: Vec<(Cell, f64)> = ranked
                .into_iter()
                .take(self.cfg.alternatives.max(1))
                .enumerate()
                .filter(|&(i, (_, q))| i == 0 || q >= self.cfg.min_prob * best)
                .map(|(_, (k, q))| (Cell((k + 1).min(63) as u8), f64::from(q.max(1e-9)).ln()))
                .collect();
            let mut next: Vec<(Vec<Cell>, f64)> = Vec::with_capacity(beam.len() * options.len());
            for (cells, s) in &beam {
                for &(c, lp) in &options {
                    let mut v = cells.clone();
                    v.push(c);
                    next.push((v, s + lp));
                }
            }
            next.sort_by(|a, b| b.1.total_cmp(&a.1));
            next.truncate(self.cfg.beam.max(1));
            beam = next;
        }
        beam.into_iter()
            .map(|(cells, s)| {
                let text = self.translator.to_text(&cells);
                let score = s + self.cfg.lm_weight * self.log_prior(&text);
                (text, score, cells)
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The print of a read word: with probabilities per cell, the beam's best; else as read.
    pub fn correct(&self, cells: &[Cell], probs: &[Vec<f32>]) -> String {
        if probs.len() == cells.len() && probs.iter().all(|p| p.len() == 63) && !probs.is_empty() {
            self.decode(probs)
        } else {
            self.as_read(cells)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::code::parse_cells;

    fn probs(cells: &[Cell], sure: f32) -> Vec<Vec<f32>> {
        cells
            .iter()
            .map(|c| {
                let mut p = vec![(1.0 - sure) / 62.0; 63];
                p[c.0 as usize - 1] = sure;
                p
            })
            .collect()
    }

    #[test]
    fn sure_cells_read_as_printed_and_a_doubtful_contraction_goes_to_the_word() {
        let s = CellSpeller::new(BrailleCode::UebGrade2, CellSpellConfig::default()).unwrap();
        // "children" is ⠡⠝ in contracted UEB; "Knowledge," ⠠⠅⠨⠂
        for print in ["children", "Knowledge,", "112"] {
            let cells = BrailleCode::UebGrade2.translator().unwrap().to_cells(print).unwrap();
            assert_eq!(s.decode(&probs(&cells, 0.9)), print);
            assert_eq!(s.as_read(&cells), print);
        }
        // "water" ⠺⠁⠞⠻ with the classifier leaning to ⠾ (one dot more) over ⠞ at the third
        // cell: the lexicon picks "water"
        let cells = parse_cells("⠺⠁⠞⠻").unwrap();
        let mut p = probs(&cells, 0.9);
        p[2] = vec![0.001; 63];
        p[2][0b111110 - 1] = 0.5; // ⠾
        p[2][0b011110 - 1] = 0.4; // ⠞
        assert_eq!(s.decode(&p), "water");
        assert!(s.log_prior("water") > s.log_prior("wa)er"));
        assert_eq!(s.log_prior("..."), CellSpellConfig::default().p_oov.ln());
    }
}
