//! From per-frame detections to words: the paper's temporal filter.
//!
//! Frames are 10 ms; a detection is a frame in which the segmentation network says a character
//! is present, with the classifier's letter and confidence. Detections less than `max_gap_ms`
//! apart form one segment; a segment of at least `min_frames` detections registers one character
//! (the letter detected most often in it; a tie goes to the higher summed confidence); a gap of
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
    /// Mean confidence of the detections of this letter.
    pub confidence: f32,
    pub frames: usize,
}

/// Words read from a stream, each a run of characters.
pub fn filter(detections: &[Detection], cfg: &TemporalFilterConfig) -> Vec<Vec<ReadChar>> {
    let max_gap = (cfg.max_gap_ms * 1e3) as i64;
    let word_gap = (cfg.word_gap_ms * 1e3) as i64;
    let mut segments: Vec<&[Detection]> = Vec::new();
    let mut start = 0;
    for i in 1..=detections.len() {
        if i == detections.len() || detections[i].t_us - detections[i - 1].t_us >= max_gap {
            if i > start {
                segments.push(&detections[start..i]);
            }
            start = i;
        }
    }
    let mut words: Vec<Vec<ReadChar>> = Vec::new();
    let mut last_end: Option<i64> = None;
    for seg in segments {
        if seg.len() < cfg.min_frames {
            continue;
        }
        // Majority letter; ties to the larger summed confidence, then the earlier letter.
        let mut votes: Vec<(char, usize, f32)> = Vec::new();
        for d in seg {
            match votes.iter_mut().find(|v| v.0 == d.letter) {
                Some(v) => {
                    v.1 += 1;
                    v.2 += d.confidence;
                }
                None => votes.push((d.letter, 1, d.confidence)),
            }
        }
        votes.sort_by(|a, b| b.1.cmp(&a.1).then(b.2.total_cmp(&a.2)).then(a.0.cmp(&b.0)));
        let (letter, n, sum) = votes[0];
        let c = ReadChar {
            letter,
            t_start_us: seg[0].t_us,
            t_end_us: seg[seg.len() - 1].t_us,
            confidence: sum / n as f32,
            frames: seg.len(),
        };
        let new_word = last_end.is_none_or(|e| c.t_start_us - e > word_gap);
        last_end = Some(c.t_end_us);
        if new_word {
            words.push(vec![c]);
        } else if let Some(w) = words.last_mut() {
            w.push(c);
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
    fn gaps_of_70_ms_split_segments_and_majorities_decide() {
        let mut d = frames('E', 0, 3);
        d.push(Detection { t_us: 30_000, letter: 'A', confidence: 0.4 });
        d.extend(frames('E', 40, 2)); // one segment of 6: E wins 5 to 1
        d.extend(frames('X', 120, 4)); // 70 ms after the last E: a new segment
        let words = filter(&d, &TemporalFilterConfig::default());
        assert_eq!(text(&words), vec!["EX".to_string()]);
    }
}
