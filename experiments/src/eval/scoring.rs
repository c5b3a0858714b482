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

pub use corpus::boards::LetterPlace;
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

/// Mean and sample standard deviation (n - 1; NaN for one value) of `values`; `None` if empty.
pub fn mean_sd(values: &[f64]) -> Option<(f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let sd = if values.len() > 1 {
        (values.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        f64::NAN
    };
    Some((mean, sd))
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

/// One step of an alignment of a sequence read to the one printed: indices into both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// `truth[i]` read as itself at `read[j]`.
    Hit(usize, usize),
    /// `truth[i]` read as something else, `read[j]`.
    Sub(usize, usize),
    /// `truth[i]` not read.
    Del(usize),
    /// `read[j]` read where nothing was printed.
    Ins(usize),
}

/// The steps of an alignment of least edits (Levenshtein, unit costs; of those, the one with the
/// most matches), in order along both sequences.
pub fn alignment<T: PartialEq>(truth: &[T], read: &[T]) -> Vec<Step> {
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
    let mut steps = Vec::with_capacity(n.max(m));
    let (mut i, mut j) = (n, m);
    while i > 0 || j > 0 {
        let here = cost[i][j];
        if i > 0 && j > 0 {
            let same = truth[i - 1] == read[j - 1];
            let (e, h) = cost[i - 1][j - 1];
            if (same && here == (e, h - 1)) || (!same && here == (e + 1, h)) {
                steps.push(if same { Step::Hit(i - 1, j - 1) } else { Step::Sub(i - 1, j - 1) });
                (i, j) = (i - 1, j - 1);
                continue;
            }
        }
        if i > 0 && here == (cost[i - 1][j].0 + 1, cost[i - 1][j].1) {
            steps.push(Step::Del(i - 1));
            i -= 1;
        } else {
            steps.push(Step::Ins(j - 1));
            j -= 1;
        }
    }
    steps.reverse();
    steps
}

impl EditCounts {
    /// Aligns `read` to `truth` ([`alignment`]) and counts the steps.
    pub fn align<T: PartialEq>(truth: &[T], read: &[T]) -> EditCounts {
        EditCounts::of_steps(truth.len(), &alignment(truth, read))
    }

    /// The counts of an alignment's steps against `reference` items printed.
    pub fn of_steps(reference: usize, steps: &[Step]) -> EditCounts {
        let mut c = EditCounts { reference, ..Default::default() };
        for s in steps {
            match s {
                Step::Hit(..) => c.hits += 1,
                Step::Sub(..) => c.substitutions += 1,
                Step::Del(_) => c.deletions += 1,
                Step::Ins(_) => c.insertions += 1,
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

/// Items printed and items of them read right.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Tally {
    pub printed: usize,
    pub right: usize,
}

impl Tally {
    /// The rate as a percentage with one decimal, a dash when nothing was printed (tables).
    pub fn percent(&self) -> String {
        if self.printed == 0 { "–".into() } else { format!("{:.1}%", 100.0 * self.rate()) }
    }

    fn add(&mut self, right: bool) {
        self.printed += 1;
        self.right += usize::from(right);
    }

    fn merge(&mut self, o: &Tally) {
        self.printed += o.printed;
        self.right += o.right;
    }

    /// Right over printed; NaN when nothing was printed.
    pub fn rate(&self) -> f64 {
        if self.printed == 0 { f64::NAN } else { self.right as f64 / self.printed as f64 }
    }
}

/// Columns of [`LetterScores::confusion`] past the 26 letters: read as a space (the word split
/// there), or not read at all.
pub const READ_SPACE: usize = 26;
pub const READ_NOTHING: usize = 27;

/// The printed letters scored one by one, in the alignment of each line's characters (spaces
/// included) to the truth: a letter is read right when the alignment matches it with itself.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct LetterScores {
    /// Per letter A-Z.
    pub by_letter: Vec<Tally>,
    /// Per place in the row, in [`LetterPlace::ALL`]'s order, over every letter.
    pub by_place: Vec<Tally>,
    /// Per letter and place: `[letter][place]`.
    pub by_letter_place: Vec<Vec<Tally>>,
    /// `confusion[printed][read]`: a printed letter A-Z read as A-Z (0-25), as a space
    /// ([`READ_SPACE`]) or as nothing ([`READ_NOTHING`]); hits on the diagonal. Characters read
    /// where nothing was printed are the character alignment's insertions.
    pub confusion: Vec<Vec<u32>>,
}

impl Default for LetterScores {
    fn default() -> LetterScores {
        LetterScores {
            by_letter: vec![Tally::default(); 26],
            by_place: vec![Tally::default(); LetterPlace::ALL.len()],
            by_letter_place: vec![vec![Tally::default(); LetterPlace::ALL.len()]; 26],
            confusion: vec![vec![0; 28]; 26],
        }
    }
}

/// One confusion of [`LetterScores::confusions`]: `printed` read as `read` (a letter, `' '` for a
/// split word, `None` for nothing read), `count` times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ConfusionPair {
    pub printed: char,
    pub read: Option<char>,
    pub count: u32,
}

impl ConfusionPair {
    /// What was read, `space` for a split word and `nothing` when nothing was read.
    pub fn read_as(&self, space: &str, nothing: &str) -> String {
        match self.read {
            Some(' ') => space.to_string(),
            Some(c) => c.to_string(),
            None => nothing.to_string(),
        }
    }
}

impl LetterScores {
    /// Every wrong reading of a printed letter, most frequent first (ties in the alphabet's order).
    pub fn confusions(&self) -> Vec<ConfusionPair> {
        let mut out: Vec<ConfusionPair> = (0..26)
            .flat_map(|p| (0..28).map(move |r| (p, r)))
            .filter(|&(p, r)| p != r && self.confusion[p][r] > 0)
            .map(|(p, r)| ConfusionPair {
                printed: letter(p),
                read: match r {
                    READ_SPACE => Some(' '),
                    READ_NOTHING => None,
                    _ => Some(letter(r)),
                },
                count: self.confusion[p][r],
            })
            .collect();
        out.sort_by_key(|p| std::cmp::Reverse(p.count));
        out
    }

    /// The place tally of `place`.
    pub fn at(&self, place: LetterPlace) -> Tally {
        self.by_place[place.index()]
    }

    /// Accuracy at `place`, and what the same letters score at `other`, each letter weighted as
    /// it is printed at `place` (letters never printed at `other` left out of both): a place's
    /// effect with the letters held fixed. NaN when no letter is printed at both.
    pub fn place_against(&self, place: LetterPlace, other: LetterPlace) -> (f64, f64) {
        let (mut n, mut here, mut there) = (0.0, 0.0, 0.0);
        for t in &self.by_letter_place {
            let (a, b) = (t[place.index()], t[other.index()]);
            if a.printed > 0 && b.printed > 0 {
                n += a.printed as f64;
                here += a.right as f64;
                there += a.printed as f64 * b.rate();
            }
        }
        if n == 0.0 { (f64::NAN, f64::NAN) } else { (here / n, there / n) }
    }

    /// All printed letters.
    pub fn total(&self) -> Tally {
        let mut t = Tally::default();
        self.by_letter.iter().for_each(|l| t.merge(l));
        t
    }

    fn merge(&mut self, o: &LetterScores) {
        self.by_letter.iter_mut().zip(&o.by_letter).for_each(|(a, b)| a.merge(b));
        self.by_place.iter_mut().zip(&o.by_place).for_each(|(a, b)| a.merge(b));
        for (a, b) in self.by_letter_place.iter_mut().zip(&o.by_letter_place) {
            a.iter_mut().zip(b).for_each(|(x, y)| x.merge(y));
        }
        for (a, b) in self.confusion.iter_mut().zip(&o.confusion) {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
    }

    /// Scores the letters of one line from its character alignment.
    fn add_line(&mut self, truth: &[String], printed: &[char], read: &[char], steps: &[Step]) {
        // The place of each printed character that is a letter.
        let mut place = Vec::with_capacity(printed.len());
        for (w, word) in truth.iter().enumerate() {
            if w > 0 {
                place.push(None);
            }
            let len = word.chars().count();
            place.extend((0..len).map(|i| Some(LetterPlace::of(w, i, len))));
        }
        debug_assert_eq!(place.len(), printed.len());
        let column = |c: char| match c {
            'A'..='Z' => (c as u8 - b'A') as usize,
            ' ' => READ_SPACE,
            _ => READ_NOTHING,
        };
        for s in steps {
            let (i, read_as) = match *s {
                Step::Hit(i, j) | Step::Sub(i, j) => (i, column(read[j])),
                Step::Del(i) => (i, READ_NOTHING),
                Step::Ins(_) => continue,
            };
            let c = printed[i];
            let (Some(p), true) = (place[i], c.is_ascii_uppercase()) else { continue };
            let k = (c as u8 - b'A') as usize;
            let right = read_as == k;
            self.by_letter[k].add(right);
            self.by_place[p.index()].add(right);
            self.by_letter_place[k][p.index()].add(right);
            self.confusion[k][read_as] += 1;
        }
    }
}

fn letter(k: usize) -> char {
    (b'A' + k as u8) as char
}

/// Printed words by their place in the row, each read right or not in the line's word alignment
/// (percent correct by place: blind to inserted words, which have no printed place).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct WordPlaces {
    /// The row's first word.
    pub first: Tally,
    /// Words between the first and the last.
    pub middle: Tally,
    /// The row's last word (a one-word row's word is its first).
    pub last: Tally,
}

impl WordPlaces {
    fn add_line(&mut self, truth_len: usize, steps: &[Step]) {
        for s in steps {
            let (i, right) = match *s {
                Step::Hit(i, _) => (i, true),
                Step::Sub(i, _) | Step::Del(i) => (i, false),
                Step::Ins(_) => continue,
            };
            let t = if i == 0 {
                &mut self.first
            } else if i + 1 == truth_len {
                &mut self.last
            } else {
                &mut self.middle
            };
            t.add(right);
        }
    }

    fn merge(&mut self, o: &WordPlaces) {
        self.first.merge(&o.first);
        self.middle.merge(&o.middle);
        self.last.merge(&o.last);
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
    /// Every printed letter, unconditionally: per letter, per place in the row, and what it was
    /// read as.
    pub letter_scores: LetterScores,
    /// Every printed word by its place in the row.
    pub word_places: WordPlaces,
}

impl WordMetrics {
    /// Adds one line: the words printed and the words read, in order.
    pub fn add_line(&mut self, truth: &[String], read: &[String]) {
        self.lines += 1;
        let word_steps = alignment(truth, read);
        self.word_edits.add(&EditCounts::of_steps(truth.len(), &word_steps));
        self.word_places.add_line(truth.len(), &word_steps);
        let chars = |w: &[String]| w.join(" ").chars().collect::<Vec<char>>();
        let (printed, read_chars) = (chars(truth), chars(read));
        let char_steps = alignment(&printed, &read_chars);
        self.char_edits.add(&EditCounts::of_steps(printed.len(), &char_steps));
        self.letter_scores.add_line(truth, &printed, &read_chars, &char_steps);
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

    /// Adds another set of lines' counts.
    pub fn merge(&mut self, o: &WordMetrics) {
        self.word_edits.add(&o.word_edits);
        self.char_edits.add(&o.char_edits);
        self.lines += o.lines;
        self.lines_with_right_word_count += o.lines_with_right_word_count;
        self.words += o.words;
        self.words_with_right_letter_count += o.words_with_right_letter_count;
        self.correct_words += o.correct_words;
        self.letters += o.letters;
        self.correct_letters += o.correct_letters;
        self.letter_scores.merge(&o.letter_scores);
        self.word_places.merge(&o.word_places);
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
    fn letters_are_scored_by_letter_place_and_what_they_were_read_as() {
        let mut m = WordMetrics::default();
        // dot 4 missed at the row's start (P as L) and at a word's start (Z as Y)
        m.add_line(&w("PUT ZOO"), &w("LUT YOO"));
        // a word split in its second letter, and a letter lost at a word's end
        m.add_line(&w("WATER HELP"), &w("W TER HEL"));
        let l = &m.letter_scores;
        let at = |c: char| l.by_letter[(c as u8 - b'A') as usize];
        assert_eq!(at('P'), Tally { printed: 2, right: 0 });
        assert_eq!(at('Z'), Tally { printed: 1, right: 0 });
        assert_eq!(at('O'), Tally { printed: 2, right: 2 });
        assert_eq!(at('A'), Tally { printed: 1, right: 0 });
        assert_eq!(at('Q'), Tally::default());
        assert!(at('Q').rate().is_nan());
        // row starts P, W; word starts Z, H; ends T, O, R, P; the rest inside
        assert_eq!(l.at(LetterPlace::RowStart), Tally { printed: 2, right: 1 });
        assert_eq!(l.at(LetterPlace::WordStart), Tally { printed: 2, right: 1 });
        assert_eq!(l.at(LetterPlace::Middle), Tally { printed: 1 + 1 + 3 + 2, right: 1 + 1 + 2 + 2 });
        assert_eq!(l.at(LetterPlace::WordEnd), Tally { printed: 4, right: 3 });
        assert_eq!(l.total(), Tally { printed: 15, right: 11 });
        // P at a row's start (wrong) and a word's end (deleted); W at a row's start (right)
        let p = (b'P' - b'A') as usize;
        assert_eq!(l.by_letter_place[p][LetterPlace::RowStart.index()], Tally { printed: 1, right: 0 });
        assert_eq!(l.by_letter_place[p][LetterPlace::WordEnd.index()], Tally { printed: 1, right: 0 });
        // row starts P (wrong) and W (right) against later word starts Z (wrong) and H (right):
        // no letter at both
        assert!(l.place_against(LetterPlace::RowStart, LetterPlace::WordStart).0.is_nan());
        // word ends T, O, R right, P deleted; of them only T (WATER's) and O (ZOO's second) stand
        // inside a word too, right there and at the end
        assert_eq!(l.place_against(LetterPlace::WordEnd, LetterPlace::Middle), (1.0, 1.0));
        assert_eq!(
            l.confusions(),
            vec![
                ConfusionPair { printed: 'A', read: Some(' '), count: 1 },
                ConfusionPair { printed: 'P', read: Some('L'), count: 1 },
                ConfusionPair { printed: 'P', read: None, count: 1 },
                ConfusionPair { printed: 'Z', read: Some('Y'), count: 1 },
            ]
        );
        // words: both first words wrong (LUT, W + TER), the last ones wrong (YOO, HEL)
        assert_eq!(m.word_places.first, Tally { printed: 2, right: 0 });
        assert_eq!(m.word_places.last, Tally { printed: 2, right: 0 });
        assert_eq!(m.word_places.middle, Tally::default());
        let mut three = WordMetrics::default();
        three.add_line(&w("ONE TWO THREE FOUR"), &w("ONE TWO THREE FOUR"));
        assert_eq!(three.word_places.middle, Tally { printed: 2, right: 2 });
        // merging equals adding the lines to one
        let mut merged = m.clone();
        merged.merge(&three);
        m.add_line(&w("ONE TWO THREE FOUR"), &w("ONE TWO THREE FOUR"));
        assert_eq!(merged, m);
    }

    #[test]
    fn an_alignments_steps_walk_both_sequences_in_order() {
        let v = |s: &str| s.chars().collect::<Vec<_>>();
        let steps = alignment(&v("KITTEN"), &v("SITTING"));
        assert_eq!(
            steps,
            vec![
                Step::Sub(0, 0),
                Step::Hit(1, 1),
                Step::Hit(2, 2),
                Step::Hit(3, 3),
                Step::Sub(4, 4),
                Step::Hit(5, 5),
                Step::Ins(6)
            ]
        );
        assert_eq!(alignment(&v("AB"), &v("B")), vec![Step::Del(0), Step::Hit(1, 0)]);
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
