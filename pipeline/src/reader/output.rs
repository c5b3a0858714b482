//! What a reader gives: characters, words and the counters of its stream.

use crate::words::ReadChar;
use serde::Serialize;

/// A finished word.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReadWord {
    /// As corrected by the speller.
    pub text: String,
    /// The letters as registered.
    pub raw: String,
    pub chars: Vec<ReadChar>,
    /// Its lexicon score per letter ([`crate::abstain::score_per_char`]; with a
    /// reader that abstains).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lexicon_score_per_char: Option<f64>,
    /// The reader could not read it: its letters make no likely word. It is given out so
    /// that the stretch is marked, not as a word of the text.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub unreadable: bool,
}

/// A word as `braille read` prints it: its start in the stream, the word, and what was registered.
impl std::fmt::Display for ReadWord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let start_s = self.chars.first().map_or(0, |c| c.t_start_us) as f64 / 1e6;
        let text = if self.unreadable { "[unreadable]" } else { &self.text };
        write!(f, "{start_s:>9.3} s  {text:<12} (read {}, {} characters)", self.raw, self.chars.len())
    }
}

/// What the reader gives as the stream goes on.
#[derive(Debug, Clone, PartialEq)]
pub enum ReadOutput {
    /// A character registered (its word may still grow).
    Char(ReadChar),
    /// A word is complete.
    Word(ReadWord),
}

/// Counters of one stream.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ReaderStats {
    pub events: u64,
    /// Events the background-activity filter removed (with `ReaderConfig::denoise`).
    pub events_denoised: u64,
    /// With the filter: the stream's uncorrelated activity per pixel, estimated from what it
    /// removed (`encoders::denoise::BackgroundActivityFilter::background_rate_hz_per_pixel`;
    /// set when the stream ends).
    pub background_hz_per_pixel: Option<f64>,
    /// Events outside the sensor or the active columns (dropped, as in training).
    pub events_masked: u64,
    pub frames: u64,
    /// Frames whose window held no event (background without asking the network).
    pub frames_empty: u64,
    pub segmenter_calls: u64,
    pub classifier_calls: u64,
    pub characters: u64,
    pub words: u64,
    /// Of them, words given out unreadable (with a reader that abstains).
    pub words_unreadable: u64,
    /// Speed estimates given by the estimator, and changes of the reader's speed they caused.
    pub speed_estimates: u64,
    pub speed_changes: u64,
    /// The speed the reader was reading at when the stream ended.
    pub speed_mm_s: Option<f64>,
}
