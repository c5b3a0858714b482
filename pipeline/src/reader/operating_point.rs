//! Where a reader reads its segmentation network: the threshold and shortest segment, and how they
//! were chosen.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Where a reader reads a segmentation network: the probability of "character" above which a
/// frame is a detection, and the fewest detections in a row (frames) that make a character. The
/// paper's are 0.5 and 4 ([`OperatingPoint::PAPER`]). A segmentation network's own point is
/// chosen on validation data (`braille calibrate-reader`) and kept in its model file, so every
/// reader of that network reads it there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OperatingPoint {
    #[serde(serialize_with = "serialize_as_printed")]
    pub present_threshold: f32,
    pub min_frames: usize,
    /// How the point was chosen (none: the paper's point, or set by hand).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<PointCalibration>,
    /// Where the reader abstains: a word whose lexicon score per letter ([`crate::abstain`]) is
    /// under the threshold is given out unreadable instead of as a word
    /// (`None`: every word is given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub abstain: Option<Abstention>,
}

/// The threshold of a reader's abstention, and how it was chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Abstention {
    /// The least lexicon score per letter of a word given out (natural log).
    pub min_score_per_char: f64,
    /// How it was chosen: the command, the validation data and the rule.
    pub chosen_by: String,
}

/// How an operating point was chosen (`braille calibrate-reader`): on what data, by which rule,
/// over which grid, and the validation scores of the point chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointCalibration {
    pub command: String,
    /// The validation data (SIMULATED validation words, their world and scans).
    pub data: String,
    /// The classifier the segmentation network was read with.
    pub classifier: String,
    pub rule: String,
    /// The chosen point's mean word accuracy over the validation speeds, without spelling and
    /// with the lexicon, as `rule` measures it (1 - WER since 2026-11-26; percent correct,
    /// blind to inserted words, in files calibrated before).
    pub mean_word_accuracy_none: f64,
    pub mean_word_accuracy_lexicon: f64,
    pub grid: CalibrationGrid,
}

/// The points a calibration tried: every threshold with every shortest segment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationGrid {
    pub thresholds: Vec<f64>,
    pub min_frames: Vec<usize>,
}

impl OperatingPoint {
    /// The paper's: a detection above 0.5, a character from 4 detections.
    pub const PAPER: OperatingPoint =
        OperatingPoint { present_threshold: 0.5, min_frames: 4, calibration: None, abstain: None };

    /// Checks the values: a threshold in [0, 1) and at least one frame.
    pub fn validate(&self) -> Result<()> {
        if !(0.0..1.0).contains(&self.present_threshold) || self.min_frames == 0 {
            return Err(Error::Setting {
                name: "operating point (threshold, shortest segment)",
                value: format!("{}, {} frames", self.present_threshold, self.min_frames),
                expected: "a threshold in [0, 1) and at least one frame",
            });
        }
        Ok(())
    }
}

/// An `f32` as the `f64` of its shortest decimal form (0.95 stays 0.95 where `as f64` gives
/// 0.949999988079071): for JSON built through `serde_json::Value`, which holds only `f64`.
pub fn f32_as_printed(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}

fn serialize_as_printed<S: serde::Serializer>(x: &f32, s: S) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_f64(f32_as_printed(*x))
}

impl Default for OperatingPoint {
    fn default() -> Self {
        OperatingPoint::PAPER
    }
}
