//! Beyond the paper: a Braille-aware lexicon decoder. It reads a word from the classifier's
//! per-letter probabilities rather than from its top letters, knows which letters Braille
//! confuses (a missed or extra dot turns E into A), allows characters that segmentation split or
//! merged (insertions and deletions), and weighs words by their frequency. Stateless per scan.
//!
//! Score of a lexicon word `w` for observations `o_1..o_m` (log domain):
//! `lm_weight * log P(w) + best alignment`, where aligning `o_i` to letter `t` scores
//! `log((1 - e) p_i(t) + e * sum_o p_i(o) C(o -> t))` with `C` the dot-pattern confusion (each
//! differing dot costs a factor `dot_factor`), an extra observation scores `log p_insert` and a
//! missing letter `log p_delete`. A string outside the lexicon competes as
//! `lm_weight * log p_oov + sum log max_t p_i(t)`, so unknown words are kept when the evidence is strong.

use encoders::braille::cell_of;
use std::collections::HashMap;

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LexiconConfig {
    /// Weight of the dot-confusion channel against the classifier's own probabilities.
    pub confusion_weight: f64,
    /// Relative likelihood of a letter being read as one that differs by one dot.
    pub dot_factor: f64,
    pub p_insert: f64,
    pub p_delete: f64,
    /// Prior of a word outside the lexicon.
    pub p_oov: f64,
    /// Weight of the word frequencies (a language-model weight below 1 keeps frequent short
    /// words from swallowing longer ones).
    pub lm_weight: f64,
    /// Lexicon words considered differ in length by at most this.
    pub max_length_change: usize,
}

impl Default for LexiconConfig {
    fn default() -> Self {
        Self {
            confusion_weight: 0.3,
            dot_factor: 0.2,
            p_insert: 0.005,
            p_delete: 0.005,
            p_oov: 1e-12,
            lm_weight: 0.5,
            max_length_change: 2,
        }
    }
}

/// Per observed character: probabilities of the 26 letters A..Z.
pub type LetterProbs = [f32; 26];

/// One-hot probabilities for a read string (for classifiers that give only letters).
pub fn one_hot(word: &str, confidence: f32) -> Vec<LetterProbs> {
    word.chars()
        .filter_map(|c| {
            let i = (c.to_ascii_uppercase() as u8).checked_sub(b'A').filter(|&i| i < 26)?;
            let mut p = [(1.0 - confidence) / 25.0; 26];
            p[i as usize] = confidence;
            Some(p)
        })
        .collect()
}

pub struct LexiconDecoder {
    cfg: LexiconConfig,
    /// Words (upper case, A-Z only) by length, with log prior and place in the list among the
    /// words of their length; most probable first (ties in the list's order).
    by_len: HashMap<usize, Vec<(Vec<u8>, f64, u32)>>,
    /// `confusion[o][t]`: P(read o | printed t), rows normalised.
    confusion: [[f64; 26]; 26],
}

impl LexiconDecoder {
    /// A decoder over `word count` lines (`;;;` comments skipped).
    pub fn from_list(text: &str, cfg: LexiconConfig) -> LexiconDecoder {
        let mut words: Vec<(Vec<u8>, f64)> = Vec::new();
        for line in text.lines().filter(|l| !l.starts_with(";;;")) {
            let mut it = line.split_whitespace();
            let (Some(w), Some(f)) = (it.next(), it.next().and_then(|f| f.parse::<f64>().ok())) else { continue };
            if !w.is_empty() && w.bytes().all(|b| b.is_ascii_alphabetic()) {
                words.push((w.to_ascii_uppercase().into_bytes(), f));
            }
        }
        let total: f64 = words.iter().map(|w| w.1).sum::<f64>().max(1.0);
        let mut by_len: HashMap<usize, Vec<(Vec<u8>, f64, u32)>> = HashMap::new();
        for (w, f) in words {
            let list = by_len.entry(w.len()).or_default();
            let place = list.len() as u32;
            list.push((w, (f / total).ln(), place));
        }
        for list in by_len.values_mut() {
            list.sort_by(|a, b| b.1.total_cmp(&a.1));
        }
        let dots = |i: usize| cell_of((b'A' + i as u8) as char).map_or(0u8, |c| c.0);
        let mut confusion = [[0.0; 26]; 26];
        for (t, _) in (0..26).enumerate() {
            let mut col = [0.0; 26];
            for (o, c) in col.iter_mut().enumerate() {
                *c = cfg.dot_factor.powi((dots(o) ^ dots(t)).count_ones() as i32);
            }
            let s: f64 = col.iter().sum();
            for o in 0..26 {
                confusion[o][t] = col[o] / s;
            }
        }
        LexiconDecoder { cfg, by_len, confusion }
    }

    /// TextBlob's word list as the lexicon.
    pub fn textblob(cfg: LexiconConfig) -> LexiconDecoder {
        LexiconDecoder::from_list(include_str!("../../data/spelling/en-spelling.txt"), cfg)
    }

    /// Log-likelihood of observation `p` being printed letter `t`.
    fn emit(&self, p: &LetterProbs, t: usize) -> f64 {
        let e = self.cfg.confusion_weight;
        let via: f64 = (0..26).map(|o| p[o] as f64 * self.confusion[o][t]).sum();
        ((1.0 - e) * p[t] as f64 + e * via).max(1e-300).ln()
    }

    /// Best alignment score of `word` against the observations (`prev` and `cur`: rows of the
    /// table, reused between words).
    fn align(&self, word: &[u8], emit: &[[f64; 26]], prev: &mut Vec<f64>, cur: &mut Vec<f64>) -> f64 {
        let n = word.len();
        let (ins, del) = (self.cfg.p_insert.ln(), self.cfg.p_delete.ln());
        prev.clear();
        prev.resize(n + 1, f64::NEG_INFINITY);
        prev[0] = 0.0;
        for j in 1..=n {
            prev[j] = prev[j - 1] + del;
        }
        for e in emit {
            cur.clear();
            cur.resize(n + 1, f64::NEG_INFINITY);
            cur[0] = prev[0] + ins;
            for j in 1..=n {
                let t = (word[j - 1] - b'A') as usize;
                cur[j] = (prev[j - 1] + e[t]).max(prev[j] + ins).max(cur[j - 1] + del);
            }
            std::mem::swap(prev, cur);
        }
        prev[n]
    }

    /// Each observation's emissions, and the string outside the lexicon (the classifier's own
    /// best letters) with its score: where a decoding starts.
    fn start(&self, obs: &[LetterProbs]) -> (Vec<[f64; 26]>, (String, f64)) {
        let emit: Vec<[f64; 26]> = obs.iter().map(|p| std::array::from_fn(|t| self.emit(p, t))).collect();
        let raw: String = obs
            .iter()
            .map(|p| (b'A' + (0..26).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap_or(0) as u8) as char)
            .collect();
        let score = self.cfg.lm_weight * self.cfg.p_oov.ln()
            + emit.iter().map(|e| e.iter().cloned().fold(f64::NEG_INFINITY, f64::max)).sum::<f64>();
        (emit, (raw, score))
    }

    /// The log prior of `word` (upper case) if it is one of the lexicon's words.
    pub fn log_prior(&self, word: &str) -> Option<f64> {
        self.by_len.get(&word.len())?.iter().find(|(w, _, _)| w == word.as_bytes()).map(|w| w.1)
    }

    /// The most probable word for the observations, upper case, and its score.
    pub fn decode(&self, obs: &[LetterProbs]) -> (String, f64) {
        let (emit, mut best) = self.start(obs);
        // The lexicon's words as if tried in the list's order, by length, each taking the lead
        // only with a higher score (so the string outside the lexicon keeps a tie): the words of
        // a length are tried most probable first, and the rest are left once even a perfect
        // alignment could not reach the lead. An alignment scores each observation as a letter
        // (at most its best emission) or an insertion, and each letter not matched as a
        // deletion, of which there are at least `len - m`.
        let m = obs.len();
        let (ins, del) = (self.cfg.p_insert.ln(), self.cfg.p_delete.ln());
        let reach: f64 = emit.iter().map(|e| e.iter().cloned().fold(ins, f64::max)).sum();
        let (mut prev, mut cur) = (Vec::new(), Vec::new());
        let mut lead: Option<(usize, u32)> = None;
        for len in m.saturating_sub(self.cfg.max_length_change).max(1)..=m + self.cfg.max_length_change {
            let ceiling = reach + len.saturating_sub(m) as f64 * del;
            for (w, prior, place) in self.by_len.get(&len).map(Vec::as_slice).unwrap_or(&[]) {
                let bound = self.cfg.lm_weight * prior + ceiling;
                // (a margin for the rounding of sums taken in another order; with a negative
                // language-model weight the most probable words score least: nothing is left)
                if self.cfg.lm_weight >= 0.0 && bound + 1e-9 * (1.0 + bound.abs()) < best.1 {
                    break;
                }
                let s = self.cfg.lm_weight * prior + self.align(w, &emit, &mut prev, &mut cur);
                let earlier = lead.is_some_and(|l| (len, *place) < l);
                if s > best.1 || (s == best.1 && earlier) {
                    best = (String::from_utf8_lossy(w).into_owned(), s);
                    lead = Some((len, *place));
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decoder() -> LexiconDecoder {
        LexiconDecoder::textblob(LexiconConfig::default())
    }

    #[test]
    fn dot_confusions_and_segmentation_errors_are_undone() {
        let d = decoder();
        // a missing dot: B (dots 1, 2) read for H (dots 1, 2, 5), A (1) for E (1, 5)
        assert_eq!(d.decode(&one_hot("PUSB", 0.9)).0, "PUSH");
        assert_eq!(d.decode(&one_hot("OPAN", 0.9)).0, "OPEN");
        // a letter split in two by segmentation
        assert_eq!(d.decode(&one_hot("WAATER", 0.9)).0, "WATER");
        // a lost letter
        assert_eq!(d.decode(&one_hot("UNIVRSITY", 0.9)).0, "UNIVERSITY");
        // correct words stay
        assert_eq!(d.decode(&one_hot("PULL", 0.9)).0, "PULL");
    }

    #[test]
    fn probabilities_beat_top_letters() {
        let d = decoder();
        // position 2 is E or A almost evenly, with A slightly ahead: LAFT is no word, LEFT is
        let mut obs = one_hot("LAFT", 0.95);
        obs[1] = [0.0; 26];
        obs[1][0] = 0.52;
        obs[1][4] = 0.48;
        assert_eq!(d.decode(&obs).0, "LEFT");
    }

    /// Every word of the lexicon tried in the list's order, as the decoder did before it left
    /// the words that cannot take the lead.
    fn decode_every_word(d: &LexiconDecoder, obs: &[LetterProbs]) -> (String, f64) {
        let (emit, mut best) = d.start(obs);
        let (mut prev, mut cur) = (Vec::new(), Vec::new());
        let m = obs.len();
        for len in m.saturating_sub(d.cfg.max_length_change).max(1)..=m + d.cfg.max_length_change {
            let mut list: Vec<_> = d.by_len.get(&len).cloned().unwrap_or_default();
            list.sort_by_key(|w| w.2);
            for (w, prior, _) in &list {
                let s = d.cfg.lm_weight * prior + d.align(w, &emit, &mut prev, &mut cur);
                if s > best.1 {
                    best = (String::from_utf8_lossy(w).into_owned(), s);
                }
            }
        }
        best
    }

    #[test]
    fn leaving_the_words_that_cannot_lead_chooses_as_trying_every_word() {
        use rand::{Rng, SeedableRng};
        let d = decoder();
        // a negative language-model weight: the most probable words score least
        let rare_first =
            LexiconDecoder::textblob(LexiconConfig { lm_weight: -0.3, p_oov: 1e-3, ..LexiconConfig::default() });
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let words = ["LEFT", "RIGHT", "WATER", "UNIVERSITY", "QZXW", "A", "EXIT", "OPEN", "THE", "BRAILLE"];
        for k in 0..120 {
            // a word read with noise (a letter now and then swapped, dropped or doubled), or
            // random letters, at several confidences
            let w = words[k % words.len()];
            let mut letters: Vec<u8> = w.bytes().collect();
            if k % 3 == 1 {
                let j = rng.random_range(0..letters.len());
                letters[j] = b'A' + rng.random_range(0..26u8);
            }
            if k % 5 == 2 && letters.len() > 1 {
                letters.remove(rng.random_range(0..letters.len()));
            }
            if k % 7 == 3 {
                letters = (0..rng.random_range(1..9)).map(|_| b'A' + rng.random_range(0..26u8)).collect();
            }
            let confidence = [0.4, 0.7, 0.95, 0.999][k % 4];
            let mut obs = one_hot(std::str::from_utf8(&letters).unwrap(), confidence);
            for p in obs.iter_mut().filter(|_| k % 2 == 0) {
                for q in p.iter_mut() {
                    *q *= rng.random_range(0.5..1.5);
                }
            }
            assert_eq!(d.decode(&obs), decode_every_word(&d, &obs), "observations {k} ({w})");
            if k % 10 == 0 {
                assert_eq!(
                    rare_first.decode(&obs),
                    decode_every_word(&rare_first, &obs),
                    "observations {k}, weight -0.3"
                );
            }
        }
    }

    #[test]
    fn confident_unknown_words_are_kept() {
        let d = decoder();
        assert_eq!(d.decode(&one_hot("QZXW", 0.999)).0, "QZXW");
    }
}
