//! From per-frame detections to words: the paper's temporal filter.
//!
//! Frames are 10 ms; a detection is a frame in which the segmentation network says a character
//! is present, with the classifier's letter and confidence. Detections less than `max_gap_ms`
//! apart form one segment; a segment of at least `min_frames` detections registers one character
//! (the letter of the highest mean probability over its frames when the classifier gives
//! probabilities, else the letter detected most often; a tie goes to the higher summed
//! confidence); a gap of
//! more than `word_gap_ms` between segments ends a word. The paper's values: 4 frames, 70 ms,
//! 1 s.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TemporalFilterConfig {
    pub min_frames: usize,
    pub max_gap_ms: f64,
    pub word_gap_ms: f64,
}

impl Default for TemporalFilterConfig {
    fn default() -> Self {
        Self { min_frames: 4, max_gap_ms: 70.0, word_gap_ms: 1000.0 }
    }
}

/// What a character classifier's classes stand for, known by their number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Alphabet {
    /// 26 classes: the letters A..Z (the paper's).
    Letters,
    /// 63 classes: the raised-dot patterns of the six-dot cell, class `k` the cell of dots bits
    /// `k + 1`, written as its Unicode Braille pattern (U+2801-U+283F).
    Cells,
    /// Any other classifier: class `k` reads as letter `k` (A, B, ...; the last letter beyond).
    Other,
}

impl Alphabet {
    pub fn of_classes(n: usize) -> Alphabet {
        match n {
            26 => Alphabet::Letters,
            63 => Alphabet::Cells,
            _ => Alphabet::Other,
        }
    }

    /// The character class `k` stands for.
    pub fn symbol(self, k: usize) -> char {
        match self {
            Alphabet::Cells => encoders::braille::Cell((k + 1).min(63) as u8).unicode(),
            Alphabet::Letters | Alphabet::Other => (b'A' + k.min(25) as u8) as char,
        }
    }
}

/// One frame's detection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    pub t_us: i64,
    pub letter: char,
    pub confidence: f32,
}

/// A registered character.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReadChar {
    pub letter: char,
    /// First and last detection of its segment.
    pub t_start_us: i64,
    pub t_end_us: i64,
    /// The letter's mean probability over the segment (letters only: the mean confidence of its
    /// detections).
    pub confidence: f32,
    pub frames: usize,
    /// When the filter registered it: the first frame at which its segment had ended (stream
    /// time).
    pub t_registered_us: i64,
    /// The classifier's probabilities (the 26 letters A..Z, or the 63 cells) averaged over the
    /// segment's frames (empty when the detections carried none); what the lexicon decoders read.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub probs: Vec<f32>,
    /// The scanning speed the reader was reading at when the character registered (its own
    /// estimate, a hint, or the paper's fixed reference); `None` from the filter alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mm_s: Option<f64>,
}

/// What the filter gives as the stream goes on.
#[derive(Debug, Clone, PartialEq)]
pub enum FilterOutput {
    /// A character registered; `new_word` when more than the word gap separates it from the
    /// previous one (or it is the first).
    Char { c: ReadChar, new_word: bool },
    /// The word gap has passed since the last character: the current word is complete.
    WordEnd,
}

/// The temporal filter as a stream: detections and frame ticks in, registered characters and
/// word ends out, holding only the open segment (bounded memory on endless streams).
#[derive(Debug, Clone)]
pub struct TemporalFilter {
    max_gap_us: i64,
    word_gap_us: i64,
    min_frames: usize,
    /// The open segment: (letter, count, summed confidence), first and last detection, frames,
    /// summed probabilities.
    votes: Vec<(char, usize, f32)>,
    seg: Option<(i64, i64, usize)>,
    prob_sum: Vec<f32>,
    /// The end of the last registered character, while its word is open.
    word_open_until: Option<i64>,
    last_char_end: Option<i64>,
}

impl TemporalFilter {
    pub fn new(cfg: &TemporalFilterConfig) -> TemporalFilter {
        TemporalFilter {
            max_gap_us: (cfg.max_gap_ms * 1e3) as i64,
            word_gap_us: (cfg.word_gap_ms * 1e3) as i64,
            min_frames: cfg.min_frames,
            votes: Vec::new(),
            seg: None,
            prob_sum: Vec::new(),
            word_open_until: None,
            last_char_end: None,
        }
    }

    /// New durations (a reader retunes them as its speed estimate changes): the open segment and
    /// word are kept and judged by the new gaps from now on.
    pub fn set_durations(&mut self, cfg: &TemporalFilterConfig) {
        self.max_gap_us = (cfg.max_gap_ms * 1e3) as i64;
        self.word_gap_us = (cfg.word_gap_ms * 1e3) as i64;
        self.min_frames = cfg.min_frames;
    }

    /// A frame at `t_us` with a detection, with the classifier's probabilities when it gives
    /// them. Frames come in time order.
    pub fn detect(&mut self, d: &Detection, probs: Option<&[f32]>, out: &mut Vec<FilterOutput>) {
        self.tick(d.t_us, out);
        let (start, _, frames) = self.seg.unwrap_or((d.t_us, d.t_us, 0));
        self.seg = Some((start, d.t_us, frames + 1));
        match self.votes.iter_mut().find(|v| v.0 == d.letter) {
            Some(v) => {
                v.1 += 1;
                v.2 += d.confidence;
            }
            None => self.votes.push((d.letter, 1, d.confidence)),
        }
        if let Some(p) = probs {
            if self.prob_sum.len() != p.len() {
                self.prob_sum = vec![0.0; p.len()];
            }
            self.prob_sum.iter_mut().zip(p).for_each(|(s, &v)| *s += v);
        }
    }

    /// Time passes to `t_us` (a frame without detection, or before one): closes the open
    /// segment when the gap has reached `max_gap`, and the word when it has passed `word_gap`.
    pub fn tick(&mut self, t_us: i64, out: &mut Vec<FilterOutput>) {
        if let Some((_, last, _)) = self.seg
            && t_us - last >= self.max_gap_us
        {
            self.close(t_us, out);
        }
        if let Some(end) = self.word_open_until
            && t_us - end > self.word_gap_us
            && self.seg.is_none()
        {
            self.word_open_until = None;
            out.push(FilterOutput::WordEnd);
        }
    }

    /// The earliest time at which [`tick`](Self::tick) would give something: the open segment's
    /// end, or its word's.
    pub fn next_deadline(&self) -> Option<i64> {
        match (self.seg, self.word_open_until) {
            (Some((_, last, _)), _) => Some(last + self.max_gap_us),
            (None, Some(end)) => Some(end + self.word_gap_us + 1),
            (None, None) => None,
        }
    }

    /// The stream has ended at `t_us`: the open segment and word are closed.
    pub fn finish(&mut self, t_us: i64, out: &mut Vec<FilterOutput>) {
        if self.seg.is_some() {
            self.close(t_us, out);
        }
        if self.word_open_until.take().is_some() {
            out.push(FilterOutput::WordEnd);
        }
    }

    fn close(&mut self, t_us: i64, out: &mut Vec<FilterOutput>) {
        let Some((start, end, frames)) = self.seg.take() else { return };
        let mut votes = std::mem::take(&mut self.votes);
        let probs = std::mem::take(&mut self.prob_sum);
        if frames < self.min_frames {
            return;
        }
        let probs: Vec<f32> = probs.iter().map(|p| p / frames as f32).collect();
        let alphabet = Alphabet::of_classes(probs.len());
        let (letter, confidence) = match probs.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(&a.0)))
        {
            // With the classifier's probabilities: the letter of the highest mean probability
            // over the segment's frames (a soft vote: a frame that is sure counts more than one
            // that hesitates).
            Some((k, &p)) if alphabet != Alphabet::Other => (alphabet.symbol(k), p),
            // Letters only: the majority; ties to the larger summed confidence, then the earlier
            // letter.
            _ => {
                votes.sort_by(|a, b| b.1.cmp(&a.1).then(b.2.total_cmp(&a.2)).then(a.0.cmp(&b.0)));
                let (letter, n, sum) = votes[0];
                (letter, sum / n as f32)
            }
        };
        let c = ReadChar {
            letter,
            t_start_us: start,
            t_end_us: end,
            confidence,
            frames,
            t_registered_us: t_us,
            probs,
            speed_mm_s: None,
        };
        let new_word = self.last_char_end.is_none_or(|e| start - e > self.word_gap_us);
        if new_word && self.word_open_until.take().is_some() {
            out.push(FilterOutput::WordEnd);
        }
        self.last_char_end = Some(end);
        self.word_open_until = Some(end);
        out.push(FilterOutput::Char { c, new_word });
    }
}

/// Words read from a whole list of detections (in time order), each a run of characters.
pub fn filter(detections: &[Detection], cfg: &TemporalFilterConfig) -> Vec<Vec<ReadChar>> {
    let mut f = TemporalFilter::new(cfg);
    let mut out = Vec::new();
    for d in detections {
        f.detect(d, None, &mut out);
    }
    f.finish(detections.last().map_or(0, |d| d.t_us), &mut out);
    let mut words: Vec<Vec<ReadChar>> = Vec::new();
    for o in out {
        if let FilterOutput::Char { c, new_word } = o {
            match words.last_mut() {
                Some(w) if !new_word => w.push(c),
                _ => words.push(vec![c]),
            }
        }
    }
    words
}

/// The words as text.
pub fn text(words: &[Vec<ReadChar>]) -> Vec<String> {
    words.iter().map(|w| w.iter().map(|c| c.letter).collect()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(letter: char, from_ms: i64, n: usize) -> Vec<Detection> {
        (0..n).map(|k| Detection { t_us: (from_ms + 10 * k as i64) * 1000, letter, confidence: 0.9 }).collect()
    }

    #[test]
    fn four_frames_register_a_character_and_a_second_ends_a_word() {
        let mut d = frames('H', 0, 5);
        d.extend(frames('I', 400, 3)); // too short: noise
        d.extend(frames('I', 800, 6));
        d.extend(frames('O', 2_900, 4)); // more than 1 s after: a new word
        let words = filter(&d, &TemporalFilterConfig::default());
        assert_eq!(text(&words), vec!["HI".to_string(), "O".to_string()]);
        assert_eq!(words[0][1].frames, 6);
    }

    #[test]
    fn with_probabilities_the_mean_decides_not_the_count() {
        // three frames lean to A, two are sure of B: B has the higher mean probability
        let mut f = TemporalFilter::new(&TemporalFilterConfig::default());
        let mut out = Vec::new();
        for (k, (letter, pa, pb)) in
            [('A', 0.4, 0.35), ('B', 0.0, 0.99), ('A', 0.4, 0.35), ('B', 0.0, 0.99), ('A', 0.4, 0.35)]
                .into_iter()
                .enumerate()
        {
            let mut p = vec![0.0f32; 26];
            (p[0], p[1]) = (pa, pb);
            f.detect(&Detection { t_us: k as i64 * 10_000, letter, confidence: pa.max(pb) }, Some(&p), &mut out);
        }
        f.finish(50_000, &mut out);
        let FilterOutput::Char { c, .. } = &out[0] else { panic!("{out:?}") };
        assert_eq!(c.letter, 'B');
        assert!((c.confidence - 0.606).abs() < 1e-3, "{c:?}");
    }

    #[test]
    fn gaps_of_70_ms_split_segments_and_majorities_decide() {
        let mut d = frames('E', 0, 3);
        d.push(Detection { t_us: 30_000, letter: 'A', confidence: 0.4 });
        d.extend(frames('E', 40, 2)); // one segment of 6: E wins 5 to 1
        d.extend(frames('X', 120, 4)); // 70 ms after the last E: a new segment
        let words = filter(&d, &TemporalFilterConfig::default());
        assert_eq!(text(&words), vec!["EX".to_string()]);
    }
}
