//! The seed paper's four conditional word-reading metrics, each on the subset that passed the
//! previous one:
//! 1. words per line: scans (lines) in which the number of words read equals the truth;
//! 2. letters per word: of the words of those lines, those read with the right number of letters;
//! 3. correct words: of those words, the ones read exactly;
//! 4. correct letters: of the letters of those words, the ones read right.

use serde::Serialize;

#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct WordMetrics {
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
