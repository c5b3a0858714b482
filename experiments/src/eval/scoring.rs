//! Scoring: classifiers' outputs against the truth ([`argmax`], [`Confusion`], [`macro_f1`]), and
//! the seed paper's four conditional word-reading metrics ([`WordMetrics`]), each on the subset
//! that passed the previous one:
//! 1. words per line: scans (lines) in which the number of words read equals the truth;
//! 2. letters per word: of the words of those lines, those read with the right number of letters;
//! 3. correct words: of those words, the ones read exactly;
//! 4. correct letters: of the letters of those words, the ones read right.
//!
//! Beside them, the unconditional figures over every printed word ([`EditCounts`], as speech
//! recognition reports them, e.g. HTK's `HResults`): the word and character error rates
//! (substitutions, deletions and insertions over the printed words, or the printed characters of
//! the line with its spaces), word accuracy `1 - WER` (HTK's "Acc", which counts inserted words
//! against the reader and can fall below 0), and percent correct (HTK's "Corr": words of the truth
//! matched in an optimal alignment, over all printed words, blind to insertions). A word read as
//! two, or a line read with a word missing, counts here, where the paper's metrics drop it from
//! their denominators.

use serde::Serialize;

pub use snn::scoring::{accuracy, argmax, hits};

/// Counts of (truth, predicted) pairs over `k` classes: `counts[truth][predicted]`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Confusion {
    pub counts: Vec<Vec<u32>>,
}

impl Confusion {
    pub fn new(k: usize) -> Confusion {
        Confusion { counts: vec![vec![0; k]; k] }
    }

    /// Counts the pairs; classes outside `0..k` are an error of the caller and panic.
    pub fn from_pairs(k: usize, pairs: impl IntoIterator<Item = (usize, usize)>) -> Confusion {
        let mut c = Confusion::new(k);
        for (t, p) in pairs {
            c.add(t, p);
        }
        c
    }

    pub fn add(&mut self, truth: usize, predicted: usize) {
        self.counts[truth][predicted] += 1;
    }

    pub fn total(&self) -> u64 {
        self.counts.iter().flatten().map(|&c| c as u64).sum()
    }

    /// Pairs on the diagonal: predictions equal to the truth.
    pub fn correct(&self) -> u64 {
        (0..self.counts.len()).map(|c| self.counts[c][c] as u64).sum()
    }

    /// Correct over all; 0 when empty.
    pub fn accuracy(&self) -> f64 {
        let n = self.total();
        if n == 0 { 0.0 } else { self.correct() as f64 / n as f64 }
    }

    pub fn macro_f1(&self) -> f64 {
        macro_f1(&self.counts)
    }
}

/// Macro-averaged F1 over the classes that occur (in truth or prediction) of a confusion matrix
/// `[truth][predicted]`; 0 when nothing occurs.
pub fn macro_f1(confusion: &[Vec<u32>]) -> f64 {
    let k = confusion.len();
    let mut f1s = Vec::new();
    #[allow(clippy::needless_range_loop)] // c indexes a row and a column
    for c in 0..k {
        let tp = confusion[c][c] as f64;
        let fp: f64 = (0..k).filter(|&r| r != c).map(|r| confusion[r][c] as f64).sum();
        let fn_: f64 = (0..k).filter(|&p| p != c).map(|p| confusion[c][p] as f64).sum();
        if tp + fp + fn_ > 0.0 {
            f1s.push(2.0 * tp / (2.0 * tp + fp + fn_));
        }
    }
    if f1s.is_empty() { 0.0 } else { f1s.iter().sum::<f64>() / f1s.len() as f64 }
}

/// The edits that turn a printed sequence into the one read, in an alignment of least edits (of
/// those, the one with the most matches).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct EditCounts {
    /// Items printed.
    pub reference: usize,
    pub hits: usize,
    pub substitutions: usize,
    pub deletions: usize,
    pub insertions: usize,
}

impl EditCounts {
    /// Aligns `read` to `truth` (Levenshtein, unit costs).
    pub fn align<T: PartialEq>(truth: &[T], read: &[T]) -> EditCounts {
        let (n, m) = (truth.len(), read.len());
        // cost[i][j]: (edits, -hits) aligning truth[..i] with read[..j]
        let mut cost = vec![vec![(0usize, 0isize); m + 1]; n + 1];
        for (i, row) in cost.iter_mut().enumerate() {
            row[0] = (i, 0);
        }
        for (j, c) in cost[0].iter_mut().enumerate() {
            *c = (j, 0);
        }
        for i in 1..=n {
            for j in 1..=m {
                let same = truth[i - 1] == read[j - 1];
                let (e, h) = cost[i - 1][j - 1];
                let diag = if same { (e, h - 1) } else { (e + 1, h) };
                let del = (cost[i - 1][j].0 + 1, cost[i - 1][j].1);
                let ins = (cost[i][j - 1].0 + 1, cost[i][j - 1].1);
                cost[i][j] = diag.min(del).min(ins);
            }
        }
        let mut c = EditCounts { reference: n, ..Default::default() };
        let (mut i, mut j) = (n, m);
        while i > 0 || j > 0 {
            let here = cost[i][j];
            if i > 0 && j > 0 {
                let same = truth[i - 1] == read[j - 1];
                let (e, h) = cost[i - 1][j - 1];
                if (same && here == (e, h - 1)) || (!same && here == (e + 1, h)) {
                    if same {
                        c.hits += 1;
                    } else {
                        c.substitutions += 1;
                    }
                    (i, j) = (i - 1, j - 1);
                    continue;
                }
            }
            if i > 0 && here == (cost[i - 1][j].0 + 1, cost[i - 1][j].1) {
                c.deletions += 1;
                i -= 1;
            } else {
                c.insertions += 1;
                j -= 1;
            }
        }
        c
    }

    pub fn add(&mut self, o: &EditCounts) {
        self.reference += o.reference;
        self.hits += o.hits;
        self.substitutions += o.substitutions;
        self.deletions += o.deletions;
        self.insertions += o.insertions;
    }

    /// Matches over the items printed (percent correct, as a fraction: blind to insertions); NaN
    /// when nothing was printed.
    pub fn percent_correct(&self) -> f64 {
        if self.reference == 0 { f64::NAN } else { self.hits as f64 / self.reference as f64 }
    }

    /// `1 - error_rate`: matches less insertions over the items printed (below 0 when the reader
    /// inserts more than it reads right); NaN when nothing was printed.
    pub fn accuracy(&self) -> f64 {
        1.0 - self.error_rate()
    }

    /// Edits over the items printed (can exceed 1); NaN when nothing was printed.
    pub fn error_rate(&self) -> f64 {
        let e = self.substitutions + self.deletions + self.insertions;
        if self.reference == 0 { f64::NAN } else { e as f64 / self.reference as f64 }
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct WordMetrics {
    /// Every line, unconditionally: words and characters (spaces included) aligned to the truth.
    pub word_edits: EditCounts,
    pub char_edits: EditCounts,
    pub lines: usize,
    pub lines_with_right_word_count: usize,
    pub words: usize,
    pub words_with_right_letter_count: usize,
    pub correct_words: usize,
    pub letters: usize,
    pub correct_letters: usize,
}

impl WordMetrics {
    /// Adds one line: the words printed and the words read, in order.
    pub fn add_line(&mut self, truth: &[String], read: &[String]) {
        self.lines += 1;
        self.word_edits.add(&EditCounts::align(truth, read));
        let chars = |w: &[String]| w.join(" ").chars().collect::<Vec<char>>();
        self.char_edits.add(&EditCounts::align(&chars(truth), &chars(read)));
        if truth.len() != read.len() {
            return;
        }
        self.lines_with_right_word_count += 1;
        for (t, r) in truth.iter().zip(read) {
            self.words += 1;
            if t.chars().count() != r.chars().count() {
                continue;
            }
            self.words_with_right_letter_count += 1;
            self.correct_words += (t == r) as usize;
            self.letters += t.chars().count();
            self.correct_letters += t.chars().zip(r.chars()).filter(|(a, b)| a == b).count();
        }
    }

    fn ratio(a: usize, b: usize) -> f64 {
        if b == 0 { f64::NAN } else { a as f64 / b as f64 }
    }

    pub fn words_per_line(&self) -> f64 {
        Self::ratio(self.lines_with_right_word_count, self.lines)
    }
    pub fn letters_per_word(&self) -> f64 {
        Self::ratio(self.words_with_right_letter_count, self.words)
    }
    pub fn correct_words_rate(&self) -> f64 {
        Self::ratio(self.correct_words, self.words_with_right_letter_count)
    }
    pub fn correct_letters_rate(&self) -> f64 {
        Self::ratio(self.correct_letters, self.letters)
    }
    /// `1 - WER` over all printed words (unconditional; inserted words count against it).
    pub fn word_accuracy(&self) -> f64 {
        self.word_edits.accuracy()
    }
    /// Printed words read right (aligned to the line), over all printed words: blind to inserted
    /// words.
    pub fn percent_correct(&self) -> f64 {
        self.word_edits.percent_correct()
    }
    pub fn word_error_rate(&self) -> f64 {
        self.word_edits.error_rate()
    }
    pub fn char_error_rate(&self) -> f64 {
        self.char_edits.error_rate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn argmax_takes_the_first_of_ties() {
        assert_eq!(argmax([0.1, 0.7, 0.7, 0.2]), 1);
        assert_eq!(argmax([-3.0, -1.0]), 1);
        assert_eq!(argmax(std::iter::empty()), 0);
    }

    #[test]
    fn macro_f1_by_hand() {
        // truth 0: 3 right, 1 read as 1; truth 1: 2 right; truth 2: 1 read as 0; class 3 never occurs
        let c = Confusion::from_pairs(4, [(0, 0), (0, 0), (0, 0), (0, 1), (1, 1), (1, 1), (2, 0)]);
        // class 0: tp 3, fp 1, fn 1 -> 6/8; class 1: tp 2, fp 1, fn 0 -> 4/5; class 2: tp 0, fn 1 -> 0
        let want = (6.0 / 8.0 + 4.0 / 5.0 + 0.0) / 3.0;
        assert!((c.macro_f1() - want).abs() < 1e-12, "{} against {want}", c.macro_f1());
        assert_eq!((c.correct(), c.total()), (5, 7));
        assert!((c.accuracy() - 5.0 / 7.0).abs() < 1e-12);
        // perfect and empty
        assert_eq!(Confusion::from_pairs(3, [(0, 0), (2, 2)]).macro_f1(), 1.0);
        assert_eq!(Confusion::new(3).macro_f1(), 0.0);
        assert_eq!(Confusion::new(3).accuracy(), 0.0);
    }

    fn w(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_string).collect()
    }

    #[test]
    fn each_metric_is_conditional_on_the_previous() {
        let mut m = WordMetrics::default();
        m.add_line(&w("RIGHT LEFT EXIT OPEN"), &w("RIGHT LEFT EXIT OPEN"));
        m.add_line(&w("RIGHT LEFT EXIT OPEN"), &w("RIGHT LEFTEXIT OPEN")); // wrong word count
        m.add_line(&w("PUSH PULL STOP HELP WATER"), &w("PUSH PULL STOB HEL WATER"));
        assert_eq!(m.lines, 3);
        assert!((m.words_per_line() - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(m.words, 9);
        assert_eq!(m.words_with_right_letter_count, 8); // HEL has 3 letters
        assert_eq!(m.correct_words, 7); // STOB is wrong
        assert_eq!(m.letters, (5 + 4 + 4 + 4) + (4 + 4 + 4 + 5)); // HEL is left out
        assert_eq!(m.letters - m.correct_letters, 1);
        // unconditionally: 13 words printed; line 2 matches RIGHT and OPEN only (LEFTEXIT is one
        // substitution and one deletion); line 3 misses STOB and HEL
        assert_eq!(m.word_edits.reference, 13);
        assert_eq!(m.word_edits.hits, 4 + 2 + 3);
        assert!((m.percent_correct() - 9.0 / 13.0).abs() < 1e-12);
        assert!((m.word_error_rate() - 4.0 / 13.0).abs() < 1e-12);
        // no word inserted: word accuracy (1 - WER) equals percent correct
        assert!((m.word_accuracy() - 9.0 / 13.0).abs() < 1e-12);
        // characters: line 2 lost one space, line 3 one substitution and one deletion
        assert_eq!(m.char_edits.substitutions + m.char_edits.deletions + m.char_edits.insertions, 3);
    }

    #[test]
    fn a_word_read_as_two_counts_against_the_unconditional_figures() {
        // the case: a five-letter word read as a one- and a three-letter word
        let mut m = WordMetrics::default();
        m.add_line(&w("WATER HELP"), &w("W TER HELP"));
        assert_eq!(m.words_per_line(), 0.0);
        assert!(m.correct_words_rate().is_nan(), "the paper's metric has nothing left to count");
        assert_eq!(m.word_edits, EditCounts { reference: 2, hits: 1, substitutions: 1, deletions: 0, insertions: 1 });
        assert_eq!(m.percent_correct(), 0.5);
        assert_eq!(m.word_error_rate(), 1.0);
        // the inserted word counts: 1 hit less 1 insertion, over 2 printed
        assert_eq!(m.word_accuracy(), 0.0);
        // "WATER HELP" -> "W TER HELP": one substitution (A -> space)
        assert_eq!(m.char_edits.substitutions + m.char_edits.deletions + m.char_edits.insertions, 1);
    }

    #[test]
    fn alignments_by_hand() {
        let c = |a: &str, b: &str| EditCounts::align(&a.chars().collect::<Vec<_>>(), &b.chars().collect::<Vec<_>>());
        assert_eq!(
            c("KITTEN", "SITTING"),
            EditCounts { reference: 6, hits: 4, substitutions: 2, deletions: 0, insertions: 1 }
        );
        assert_eq!(c("", "AB"), EditCounts { reference: 0, hits: 0, substitutions: 0, deletions: 0, insertions: 2 });
        assert_eq!(c("AB", ""), EditCounts { reference: 2, hits: 0, substitutions: 0, deletions: 2, insertions: 0 });
        assert_eq!(c("ABC", "ABC").error_rate(), 0.0);
        assert!(c("", "").accuracy().is_nan());
        assert!(c("", "").percent_correct().is_nan());
        // a reader that inserts more than it reads right scores below 0 (1 - 3/1)
        let one_read_as_three = c("A", "BCD");
        assert_eq!(one_read_as_three.percent_correct(), 0.0);
        assert_eq!(one_read_as_three.accuracy(), -2.0);
        // HTK's example shape: 6 printed, 4 hits, 2 substitutions, 1 insertion -> Corr 4/6, Acc 3/6
        let k = c("KITTEN", "SITTING");
        assert!((k.percent_correct() - 4.0 / 6.0).abs() < 1e-12);
        assert!((k.accuracy() - 3.0 / 6.0).abs() < 1e-12);
    }
}
