//! The seed paper's spelling corrector: TextBlob's (Peter Norvig's algorithm). A word in the
//! list stays; otherwise the known words at edit distance 1, or else 2, compete by frequency;
//! a word with no known neighbour stays as it is. Stateless per scan.
//!
//! The word list is TextBlob's `en-spelling.txt` (MIT, `data/spelling/LICENSE.textblob`), built
//! into the binary. TextBlob keys are lower case; words are corrected in lower case and returned
//! in the case they came in (all capitals for Braille read as capitals).

use std::collections::HashMap;

pub(crate) static TEXTBLOB_WORDS: &str = include_str!("../../data/spelling/en-spelling.txt");

const ALPHABET: &[u8] = b"abcdefghijklmnopqrstuvwxyz";

/// Norvig's corrector over a frequency list.
#[derive(Debug, Clone)]
pub struct Norvig {
    words: HashMap<String, u64>,
}

impl Norvig {
    /// TextBlob's corrector with its own word list.
    pub fn textblob() -> Norvig {
        Norvig::from_list(TEXTBLOB_WORDS)
    }

    /// A corrector from lines `word count` (lines starting with `;;;` are comments).
    pub fn from_list(text: &str) -> Norvig {
        let words = text
            .lines()
            .filter(|l| !l.starts_with(";;;"))
            .filter_map(|l| {
                let mut it = l.split_whitespace();
                let (w, f) = (it.next()?, it.next()?);
                Some((w.to_string(), f.parse().ok()?))
            })
            .collect();
        Norvig { words }
    }

    /// The `n` most frequent words (ties by spelling), most frequent first.
    pub fn most_frequent(&self, n: usize) -> Vec<(&str, u64)> {
        let mut all: Vec<(&str, u64)> = self.words.iter().map(|(w, &f)| (w.as_str(), f)).collect();
        all.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
        all.truncate(n);
        all
    }

    pub fn len(&self) -> usize {
        self.words.len()
    }

    pub fn is_empty(&self) -> bool {
        self.words.is_empty()
    }

    pub fn contains(&self, word: &str) -> bool {
        self.words.contains_key(&word.to_lowercase())
    }

    /// Every string at edit distance 1: deletions, transpositions, replacements, insertions.
    fn edits1(word: &str) -> Vec<String> {
        let w: Vec<u8> = word.bytes().collect();
        let mut out = Vec::with_capacity(54 * w.len() + 25);
        for i in 0..=w.len() {
            let (a, b) = w.split_at(i);
            if !b.is_empty() {
                out.push([a, &b[1..]].concat());
            }
            if b.len() > 1 {
                out.push([a, &[b[1], b[0]], &b[2..]].concat());
            }
            for &c in ALPHABET {
                if !b.is_empty() {
                    out.push([a, &[c], &b[1..]].concat());
                }
                out.push([a, &[c], b].concat());
            }
        }
        out.into_iter().filter_map(|v| String::from_utf8(v).ok()).collect()
    }

    /// Candidates with their probability, best first (TextBlob's `suggest`).
    pub fn suggest(&self, word: &str) -> Vec<(String, f64)> {
        let w = word.to_lowercase();
        if self.words.contains_key(&w) {
            return vec![(word.to_string(), 1.0)];
        }
        let known = |cands: Vec<String>| -> Vec<String> {
            let mut k: Vec<String> = cands.into_iter().filter(|c| self.words.contains_key(c)).collect();
            k.sort();
            k.dedup();
            k
        };
        let e1 = Self::edits1(&w);
        let mut candidates = known(e1.clone());
        if candidates.is_empty() {
            candidates = known(e1.iter().flat_map(|e| Self::edits1(e)).collect());
        }
        if candidates.is_empty() {
            return vec![(word.to_string(), 1.0)];
        }
        let total: f64 = candidates.iter().map(|c| self.words[c] as f64).sum::<f64>().max(1.0);
        let mut scored: Vec<(f64, String)> =
            candidates.into_iter().map(|c| (self.words[&c] as f64 / total, c)).collect();
        // Python's sorted(..., reverse=True) on (probability, word): ties go to the later word.
        scored.sort_by(|a, b| b.0.total_cmp(&a.0).then_with(|| b.1.cmp(&a.1)));
        scored.into_iter().map(|(p, c)| (restore_case(word, &c), p)).collect()
    }

    /// The best correction of `word`.
    pub fn correct(&self, word: &str) -> String {
        self.suggest(word).into_iter().next().map(|(w, _)| w).unwrap_or_else(|| word.to_string())
    }
}

/// `candidate` in the case pattern of `original`: all capitals, a capital first letter, or lower.
fn restore_case(original: &str, candidate: &str) -> String {
    let letters: Vec<char> = original.chars().filter(|c| c.is_alphabetic()).collect();
    if !letters.is_empty() && letters.iter().all(|c| c.is_uppercase()) && letters.len() > 1 {
        candidate.to_uppercase()
    } else if letters.first().is_some_and(|c| c.is_uppercase()) {
        let mut c = candidate.chars();
        c.next().map(|f| f.to_uppercase().chain(c).collect()).unwrap_or_default()
    } else {
        candidate.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textblob_list_loads_and_corrects_like_norvig() {
        let n = Norvig::textblob();
        assert!(n.len() > 29_000, "{}", n.len());
        assert_eq!(n.correct("speling"), "spelling");
        assert_eq!(n.correct("korrectud"), "corrected");
        assert_eq!(n.correct("HELLO"), "HELLO");
        assert_eq!(n.correct("WATEE"), "WATER");
        assert_eq!(n.correct("Exot"), "Exit");
        // nothing within two edits: unchanged
        assert_eq!(n.correct("qzxqzxq"), "qzxqzxq");
    }

    #[test]
    fn edits_have_norvigs_count() {
        // n deletions, n-1 transpositions, 26n replacements, 26(n+1) insertions
        let n = 5;
        assert_eq!(Norvig::edits1("abcde").len(), n + (n - 1) + 26 * n + 26 * (n + 1));
    }

    #[test]
    fn ties_break_like_python() {
        let n = Norvig::from_list("cat 5\ncar 5\n");
        assert_eq!(n.suggest("caz")[0].0, "cat");
    }
}
