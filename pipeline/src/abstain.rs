//! A reader that cannot read says so. Where the segmenter fires on noise (background activity,
//! hot pixels, a press too light) the classifier still names a letter for every detection, and
//! the words they make are inserted into the text. Such letters make no likely English word: a
//! word's lexicon score is the log score of the best word the lexicon decoder finds for its
//! letters' probabilities (the word's prior and how the letters fit it; a word outside the
//! lexicon pays its small prior), per letter ([`score_per_char`]). A word whose score falls under
//! the reader's threshold is given out marked unreadable instead of as a word
//! ([`crate::reader::ReadWord::unreadable`]). The threshold belongs to the segmentation network's
//! operating point and is chosen on validation words, like the rest of it; a point without one
//! never abstains.
//!
//! On the validation words and sentences the measure was chosen among the letters' confidences,
//! segment lengths and the lexicon's fit without the prior (docs/protocol.md, "Abstention").
//! The score reads the paper's letters (26 probabilities a character); a cell reader's words are
//! never judged.

use crate::lexicon::{LetterProbs, LexiconDecoder};
use crate::words::ReadChar;
use std::sync::OnceLock;

/// The lexicon speller's decoder: TextBlob's word list with its default settings (built once,
/// on first use).
fn decoder() -> &'static LexiconDecoder {
    static DECODER: OnceLock<LexiconDecoder> = OnceLock::new();
    DECODER.get_or_init(|| LexiconDecoder::textblob(Default::default()))
}

/// The lexicon decoder's log score of its best word for the letters ([`LexiconDecoder::decode`]),
/// over the number of letters. `None` for an empty word or one whose characters carry no letter
/// probabilities (cells, or a filter alone).
pub fn score_per_char(chars: &[ReadChar]) -> Option<f64> {
    if chars.is_empty() {
        return None;
    }
    let obs: Vec<LetterProbs> =
        chars.iter().map(|c| <LetterProbs>::try_from(c.probs.as_slice()).ok()).collect::<Option<_>>()?;
    Some(decoder().decode(&obs).1 / chars.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn char_of(p: LetterProbs) -> ReadChar {
        ReadChar {
            letter: 'A',
            t_start_us: 0,
            t_end_us: 0,
            confidence: 1.0,
            frames: 4,
            t_registered_us: 0,
            probs: p.to_vec(),
            speed_mm_s: None,
        }
    }

    fn sure(word: &str) -> Vec<ReadChar> {
        crate::lexicon::one_hot(word, 0.98).into_iter().map(char_of).collect()
    }

    #[test]
    fn letters_of_words_score_above_letters_of_noise() {
        let word = score_per_char(&sure("GARDEN")).unwrap();
        let short = score_per_char(&sure("A")).unwrap();
        let the = score_per_char(&sure("THE")).unwrap();
        // read with confidence, yet no word
        let noise = score_per_char(&sure("GCGQG")).unwrap();
        // letters spread over several classes, as detections of noise give them
        let mut spread = [0.01f32; 26];
        for i in [2, 6, 10] {
            spread[i] = 0.3;
        }
        let vague = score_per_char(&[char_of(spread), char_of(spread)]).unwrap();
        for (name, s) in [("GARDEN", word), ("A", short), ("THE", the)] {
            assert!(s > -2.5, "{name}: {s}");
        }
        assert!(noise < -2.5 && vague < -2.5, "{noise} {vague}");
    }

    #[test]
    fn words_without_letter_probabilities_are_not_judged() {
        assert_eq!(score_per_char(&[]), None);
        let mut c = char_of([1.0 / 26.0; 26]);
        c.probs.clear();
        assert_eq!(score_per_char(&[c]), None);
    }
}
