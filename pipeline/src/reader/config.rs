//! The reader's settings: where its timing comes from, its binning, filter and denoiser.

use super::OperatingPoint;
use crate::error::{Error, Result};
use crate::grid::CellGrid;
use crate::labeling::LabelerConfig;
use crate::speed::SpeedEstimatorConfig;
use crate::words::TemporalFilterConfig;
use serde::{Deserialize, Serialize};

/// Where the reader's bin length and filter durations come from. The labeler's durations are
/// given at a reference speed (the paper's 10 ms bins, 70 ms segment gap and 1 s word gap at
/// 8 mm/s) and scale by `reference / speed`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum Timing {
    /// The speed estimated online from the events themselves ([`SpeedEstimator`](crate::speed::SpeedEstimator)); nothing the
    /// simulator knows. Until the first estimate the reader reads at `hint_mm_s` when given, and
    /// otherwise holds the events (at most [`ReaderConfig::hold_ms`] of stream) and reads them
    /// once the estimate comes, so none is lost.
    Estimated { hint_mm_s: Option<f64> },
    /// A speed told to the reader and kept (the simulator's truth makes it an oracle: a bound on
    /// what estimating the speed costs, not a deployable reader).
    Given { speed_mm_s: f64 },
    /// The paper's fixed settings whatever the speed: the reference speed's bins and gaps
    /// (10 ms, 70 ms, 1 s), for a like-for-like comparison with its table.
    Paper,
}

impl Timing {
    /// The reader's default: estimated, with no hint.
    pub const ESTIMATED: Timing = Timing::Estimated { hint_mm_s: None };

    /// The mode and speed as a command line gives them: `speed_mm_s` is the hint when estimated
    /// and required when given.
    pub fn from_mode(mode: TimingMode, speed_mm_s: Option<f64>) -> Result<Timing> {
        match (mode, speed_mm_s) {
            (TimingMode::Estimated, hint_mm_s) => Ok(Timing::Estimated { hint_mm_s }),
            (TimingMode::Given, Some(speed_mm_s)) => Ok(Timing::Given { speed_mm_s }),
            (TimingMode::Given, None) => Err(Error::Setting {
                name: "speed",
                value: "none".into(),
                expected: "a speed: timing `given` needs a speed (--speed)",
            }),
            (TimingMode::Paper, _) => Ok(Timing::Paper),
        }
    }

    pub fn mode(&self) -> TimingMode {
        match self {
            Timing::Estimated { .. } => TimingMode::Estimated,
            Timing::Given { .. } => TimingMode::Given,
            Timing::Paper => TimingMode::Paper,
        }
    }
}

/// [`Timing`] without its speeds, as a command line or a report names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum TimingMode {
    /// Speed estimated from the events (the default; a given speed is a hint).
    Estimated,
    /// The paper's fixed 10 ms bins, 70 ms and 1 s.
    Paper,
    /// A speed given and kept (with the simulator's truth: an oracle).
    Given,
}

impl std::fmt::Display for TimingMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TimingMode::Estimated => "estimated",
            TimingMode::Paper => "paper",
            TimingMode::Given => "given",
        })
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReaderConfig {
    /// Binning and window length: the labeler's, as the classifiers were trained on.
    pub labeler: LabelerConfig,
    /// Where the scanning speed comes from.
    pub timing: Timing,
    /// The online speed estimator (with [`Timing::Estimated`]).
    #[serde(default)]
    pub estimator: SpeedEstimatorConfig,
    /// With [`Timing::Estimated`] and no hint: the most stream time held before the first
    /// estimate; past it the reader starts at the reference speed.
    #[serde(default = "default_hold_ms")]
    pub hold_ms: f64,
    /// The reader's speed follows the median of the last three estimates, and changes (at a bin
    /// boundary) when that median differs from it by more than this fraction.
    #[serde(default = "default_retune_fraction")]
    pub retune_fraction: f64,
    /// The temporal filter at the labeler's reference speed (the paper's: 4 frames, 70 ms, 1 s
    /// at 8 mm/s).
    pub filter: TemporalFilterConfig,
    /// The segmentation network's probability of "character" above which a frame is a detection.
    pub present_threshold: f32,
    /// A word that reaches this many characters is given out and a new one begun (a stream
    /// without word gaps keeps memory bounded; nothing is dropped).
    #[serde(default = "default_max_word_chars")]
    pub max_word_chars: usize,
    /// Cell readers: the cell grid that puts a cell of one dot column in its column
    /// ([`crate::grid`]; `None`: the classifier's column stands). A one-column cell is given out
    /// once the next character registers or its word ends, so that the grid sees a neighbour on
    /// either side. Letter readers do not use it.
    #[serde(default = "default_cell_grid")]
    pub cell_grid: Option<CellGrid>,
    /// A background-activity filter every event passes first (`encoders::denoise`; `None`: the
    /// events as they come, as the shipped readers were trained).
    #[serde(default)]
    pub denoise: Option<encoders::denoise::NoiseFilterSettings>,
    /// A word whose lexicon score per letter is under this is given out unreadable
    /// ([`crate::abstain`]; `None`: every word is given as read).
    #[serde(default)]
    pub abstain_below_score_per_char: Option<f64>,
}

fn default_cell_grid() -> Option<CellGrid> {
    Some(CellGrid::default())
}

fn default_max_word_chars() -> usize {
    64
}

fn default_hold_ms() -> f64 {
    1000.0
}

fn default_retune_fraction() -> f64 {
    0.05
}

/// At most this many events are held before the first speed estimate (a 1 s hold of the
/// busiest readout stays under 32 MB).
pub(super) const MAX_HELD_EVENTS: usize = 2_000_000;

impl ReaderConfig {
    pub fn new(timing: Timing) -> ReaderConfig {
        ReaderConfig {
            labeler: LabelerConfig::default(),
            timing,
            estimator: SpeedEstimatorConfig::default(),
            hold_ms: default_hold_ms(),
            retune_fraction: default_retune_fraction(),
            filter: TemporalFilterConfig { min_frames: OperatingPoint::PAPER.min_frames, ..Default::default() },
            present_threshold: OperatingPoint::PAPER.present_threshold,
            max_word_chars: default_max_word_chars(),
            cell_grid: default_cell_grid(),
            denoise: None,
            abstain_below_score_per_char: None,
        }
    }

    /// A reader told the speed (the tests', and an oracle's).
    pub fn at_speed(speed_mm_s: f64) -> ReaderConfig {
        ReaderConfig::new(Timing::Given { speed_mm_s })
    }

    /// Reads the segmentation network at `point` (its threshold and shortest segment).
    pub fn with_operating_point(mut self, point: &OperatingPoint) -> ReaderConfig {
        self.present_threshold = point.present_threshold;
        self.filter.min_frames = point.min_frames;
        self.abstain_below_score_per_char = point.abstain.as_ref().map(|a| a.min_score_per_char);
        self
    }

    /// The filter's durations at `speed_mm_s`.
    pub fn scaled_filter(&self, speed_mm_s: f64) -> TemporalFilterConfig {
        let k = self.labeler.reference_speed_mm_s / speed_mm_s;
        TemporalFilterConfig {
            min_frames: self.filter.min_frames,
            max_gap_ms: self.filter.max_gap_ms * k,
            word_gap_ms: self.filter.word_gap_ms * k,
        }
    }

    /// The speed reading starts at, if known before any event.
    pub(super) fn initial_speed_mm_s(&self) -> Option<f64> {
        match self.timing {
            Timing::Estimated { hint_mm_s } => hint_mm_s,
            Timing::Given { speed_mm_s } => Some(speed_mm_s),
            Timing::Paper => Some(self.labeler.reference_speed_mm_s),
        }
    }

    pub(super) fn validate(&self) -> Result<()> {
        let speed_ok = |v: f64| v > 0.0 && v.is_finite();
        if let Some(v) = self.initial_speed_mm_s()
            && !speed_ok(v)
        {
            return Err(Error::Setting { name: "speed (mm/s)", value: v.to_string(), expected: "a positive speed" });
        }
        if self.labeler.frames == 0 {
            return Err(Error::Setting { name: "window frames", value: "0".into(), expected: "at least one frame" });
        }
        if !(self.hold_ms > 0.0 && self.retune_fraction >= 0.0) {
            return Err(Error::Setting {
                name: "hold_ms, retune_fraction",
                value: format!("{}, {}", self.hold_ms, self.retune_fraction),
                expected: "a positive hold and a fraction not negative",
            });
        }
        Ok(())
    }
}
