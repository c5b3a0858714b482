//! Reading words from an unsegmented event stream as it arrives: the paper's streaming
//! inference.
//!
//! Events are binned as the labeler bins them (10 ms at 8 mm/s, scaled with speed; pooled by 4;
//! columns outside the active region masked). The speed comes from a [`Timing`]: by default the
//! reader estimates it from the events themselves ([`SpeedEstimator`]) and retunes its bins and
//! the filter's durations as the estimate moves; the paper's fixed timing and a given speed are
//! the alternatives. Every closed bin is a frame: the window of the
//! last `frames` bins goes to the segmentation network, and only where it says a character is
//! present to the character classifier; the temporal filter turns the detections into characters
//! and words, and a speller corrects each finished word. The reader holds one window of sparse
//! bins, the filter's open segment and the open word: memory stays bounded however long the
//! stream runs.
//!
//! The classifiers are behind [`WindowClassifier`], so the ResNet and the SNN read identical
//! windows of identical streams.

use crate::cell_spell::CellSpeller;
use crate::classify::WindowModel;
use crate::code::BrailleCode;
use crate::error::{Error, Result};
use crate::grid::{CellGrid, Column, GridMark};
use crate::labeling::LabelerConfig;
use crate::lexicon::LexiconDecoder;
use crate::speed::{SpeedEstimate, SpeedEstimator, SpeedEstimatorConfig};
use crate::spelling::Norvig;
use crate::words::{Detection, FilterOutput, ReadChar, TemporalFilter, TemporalFilterConfig};
use encoders::braille::{Cell as BrailleCell, cell_on_board};
use encoders::pooling::PoolMap;
use encoders::{Event, Resolution};
use serde::{Deserialize, Serialize};
use std::hint::select_unpredictable;

/// Events summed in one pooled cell of one bin: input `polarity * cells + row * width + col`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub input: u32,
    pub count: f32,
}

/// One frame's input: the last `frames` bins, oldest first, each a sparse list of cells.
pub struct Window<'a> {
    /// The end of the newest bin.
    pub t_end_us: i64,
    /// The newest bin's length (a reader that follows its speed estimate may have changed it
    /// within the window: [`bin_ends_us`](Self::bin_ends_us) has every bin's end).
    pub bin_us: i64,
    /// The pooled grid.
    pub height: usize,
    pub width: usize,
    bins: [&'a [Vec<Cell>]; 2],
    ends_us: [&'a [i64]; 2],
}

impl Window<'_> {
    /// The bins, oldest first.
    pub fn bins(&self) -> impl Iterator<Item = &[Cell]> {
        self.bins[0].iter().chain(self.bins[1]).map(Vec::as_slice)
    }

    /// The end of each bin, oldest first.
    pub fn bin_ends_us(&self) -> impl Iterator<Item = i64> + '_ {
        self.ends_us[0].iter().chain(self.ends_us[1]).copied()
    }

    pub fn n_bins(&self) -> usize {
        self.bins[0].len() + self.bins[1].len()
    }

    /// The window as a dense heat map of the pooled grid (`[bin][polarity][row][col]`).
    pub fn heatmap(&self) -> encoders::heatmap::Heatmap {
        let plane = 2 * self.height * self.width;
        let mut counts = vec![0f32; self.n_bins() * plane];
        for (b, cells) in self.bins().enumerate() {
            for c in cells {
                counts[b * plane + c.input as usize] += c.count;
            }
        }
        encoders::heatmap::Heatmap {
            t_start_us: self.t_end_us - self.bin_us * self.n_bins() as i64,
            bin_us: self.bin_us,
            bins: self.n_bins(),
            height: self.height,
            width: self.width,
            counts,
        }
    }
}

/// A network that reads a window: class probabilities (they sum to 1). The segmentation network
/// gives `[background, character]`, a character classifier the 26 letters A..Z or the 63 cells
/// ([`crate::words::Alphabet`]).
///
/// The network is shared (`&self`): whatever a stream keeps between windows (neuron state,
/// caches, counters) lives in its own [`WindowClassifier::State`], so one loaded model serves
/// any number of streams at once.
pub trait WindowClassifier {
    type State;

    /// The state of a new stream.
    fn new_state(&self) -> Self::State;

    fn classify(&self, state: &mut Self::State, window: &Window) -> Result<Vec<f32>>;
}

/// How finished words are corrected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Spell {
    /// The letters as read.
    None,
    /// The paper's corrector: TextBlob's (Norvig's algorithm over TextBlob's word list).
    Textblob,
    /// The Braille-aware lexicon decoder over the classifier's letter probabilities.
    Lexicon,
}

/// A speller, built once.
#[allow(clippy::large_enum_variant)] // one per reader: the size does not matter
pub enum Speller {
    None,
    Textblob(Norvig),
    Lexicon(LexiconDecoder),
    /// Words of cells in a Braille code (UEB), back-translated to print: as read
    /// ([`Spell::None`]), then each run of letters corrected by TextBlob's corrector
    /// ([`Spell::Textblob`]), or the beam over the cell probabilities scored by the lexicon
    /// ([`Spell::Lexicon`], [`crate::cell_spell`]).
    Cells {
        spell: Spell,
        speller: CellSpeller,
        norvig: Option<Norvig>,
    },
}

impl Speller {
    /// The paper's letters' speller.
    pub fn new(spell: Spell) -> Speller {
        match spell {
            Spell::None => Speller::None,
            Spell::Textblob => Speller::Textblob(Norvig::textblob()),
            Spell::Lexicon => Speller::Lexicon(LexiconDecoder::textblob(Default::default())),
        }
    }

    /// A speller of words printed in `code`: the letters' for the paper's letters, else words of
    /// cells back-translated through the code's tables.
    pub fn in_code(spell: Spell, code: BrailleCode) -> Result<Speller> {
        Ok(match code {
            BrailleCode::Grade1Letters => Speller::new(spell),
            _ => Speller::Cells {
                spell,
                speller: CellSpeller::new(code, Default::default())?,
                norvig: (spell == Spell::Textblob).then(Norvig::textblob),
            },
        })
    }

    /// How it corrects.
    pub fn spell(&self) -> Spell {
        match self {
            Speller::None => Spell::None,
            Speller::Textblob(_) => Spell::Textblob,
            Speller::Lexicon(_) => Spell::Lexicon,
            Speller::Cells { spell, .. } => *spell,
        }
    }

    /// The word the characters spell, corrected.
    pub fn correct(&self, chars: &[ReadChar]) -> String {
        let raw: String = chars.iter().map(|c| c.letter).collect();
        match self {
            Speller::None => raw,
            Speller::Textblob(n) => n.correct(&raw),
            Speller::Lexicon(d) => {
                let obs: Vec<crate::lexicon::LetterProbs> = chars
                    .iter()
                    .map(|c| match <[f32; 26]>::try_from(c.probs.as_slice()) {
                        Ok(p) => p,
                        Err(_) => crate::lexicon::one_hot(&c.letter.to_string(), c.confidence.clamp(0.04, 0.999))
                            .first()
                            .copied()
                            .unwrap_or([1.0 / 26.0; 26]),
                    })
                    .collect();
                d.decode(&obs).0
            }
            Speller::Cells { spell, speller, norvig } => {
                // a letter classifier's letters are their Grade-1 cells
                let cells: Vec<BrailleCell> =
                    chars.iter().map(|c| cell_on_board(c.letter).unwrap_or(BrailleCell::EMPTY)).collect();
                match (spell, norvig) {
                    (Spell::Lexicon, _) => {
                        let probs: Vec<Vec<f32>> = chars.iter().map(|c| c.probs.clone()).collect();
                        speller.correct(&cells, &probs)
                    }
                    (Spell::Textblob, Some(n)) => correct_letter_runs(&speller.as_read(&cells), n),
                    _ => speller.as_read(&cells),
                }
            }
        }
    }
}

/// Each run of ASCII letters in `text` corrected by `n` (in its case pattern); the rest kept.
fn correct_letter_runs(text: &str, n: &Norvig) -> String {
    let mut out = String::with_capacity(text.len());
    let mut run = String::new();
    for c in text.chars().chain(std::iter::once('\0')) {
        if c.is_ascii_alphabetic() {
            run.push(c);
            continue;
        }
        if !run.is_empty() {
            out.push_str(&n.correct(&run));
            run.clear();
        }
        if c != '\0' {
            out.push(c);
        }
    }
    out
}

/// A finished word.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReadWord {
    /// As corrected by the speller.
    pub text: String,
    /// The letters as registered.
    pub raw: String,
    pub chars: Vec<ReadChar>,
}

/// A word as `braille read` prints it: its start in the stream, the word, and what was registered.
impl std::fmt::Display for ReadWord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let start_s = self.chars.first().map_or(0, |c| c.t_start_us) as f64 / 1e6;
        write!(f, "{start_s:>9.3} s  {:<12} (read {}, {} characters)", self.text, self.raw, self.chars.len())
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
    pub const PAPER: OperatingPoint = OperatingPoint { present_threshold: 0.5, min_frames: 4, calibration: None };

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

/// Where the reader's bin length and filter durations come from. The labeler's durations are
/// given at a reference speed (the paper's 10 ms bins, 70 ms segment gap and 1 s word gap at
/// 8 mm/s) and scale by `reference / speed`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum Timing {
    /// The speed estimated online from the events themselves ([`SpeedEstimator`]); nothing the
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
const MAX_HELD_EVENTS: usize = 2_000_000;

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
    fn initial_speed_mm_s(&self) -> Option<f64> {
        match self.timing {
            Timing::Estimated { hint_mm_s } => hint_mm_s,
            Timing::Given { speed_mm_s } => Some(speed_mm_s),
            Timing::Paper => Some(self.labeler.reference_speed_mm_s),
        }
    }

    fn validate(&self) -> Result<()> {
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

/// Counters of one stream.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ReaderStats {
    pub events: u64,
    /// Events the background-activity filter removed (with `ReaderConfig::denoise`).
    pub events_denoised: u64,
    /// Events outside the sensor or the active columns (dropped, as in training).
    pub events_masked: u64,
    pub frames: u64,
    /// Frames whose window held no event (background without asking the network).
    pub frames_empty: u64,
    pub segmenter_calls: u64,
    pub classifier_calls: u64,
    pub characters: u64,
    pub words: u64,
    /// Speed estimates given by the estimator, and changes of the reader's speed they caused.
    pub speed_estimates: u64,
    pub speed_changes: u64,
    /// The speed the reader was reading at when the stream ended.
    pub speed_mm_s: Option<f64>,
}

/// The streaming reader of one stream: the shared models, and this stream's state of each.
pub struct StreamReader<'m, S: WindowClassifier = WindowModel, C: WindowClassifier = WindowModel> {
    cfg: ReaderConfig,
    /// The speed being read at (`None` while events are held for the first estimate), and the
    /// bin length it gives.
    speed_mm_s: Option<f64>,
    bin_us: i64,
    /// With [`Timing::Estimated`]: the estimator, its last three estimates (a ring) and their
    /// median, the speed the reader moves to at the next bin boundary.
    estimator: Option<SpeedEstimator>,
    recent_mm_s: Vec<f64>,
    recent_head: usize,
    wanted_mm_s: Option<f64>,
    /// Events held before the first estimate.
    held: Vec<Event>,
    /// With `ReaderConfig::denoise`: the background-activity filter every event passes first.
    denoiser: Option<encoders::denoise::BackgroundActivityFilter>,
    frames: usize,
    map: PoolMap,
    cells: usize,
    /// The last `frames` bins, a ring: `ring[head]` is the oldest once full; and the end of each.
    ring: Vec<Vec<Cell>>,
    ring_end_us: Vec<i64>,
    head: usize,
    /// The bin being filled: dense counts (16 bits: half the cache lines of a float, and no cell
    /// of a bin nears 65 535 events; they saturate there) and a sink for masked events after
    /// them, and the cells touched, the first `touched_len` of `touched`, which has room for
    /// every cell and one more: each event writes its cell at `touched_len` and moves it on only
    /// when the cell was empty, so that the scattered events take no branch ([`scatter`]).
    acc: Vec<u16>,
    touched: Vec<u32>,
    touched_len: usize,
    /// Start of the bin being filled (set by the first event).
    bin_start: Option<i64>,
    /// Bins in the ring that hold an event.
    nonempty: usize,
    last_t: i64,
    segmenter: &'m S,
    classifier: &'m C,
    segmenter_state: S::State,
    classifier_state: C::State,
    filter: TemporalFilter,
    speller: &'m Speller,
    word: Vec<ReadChar>,
    /// Characters of `word` given out so far (a one-column cell waits for the cell grid).
    word_given: usize,
    /// The cell grid's marks of the current word's characters, and the last two-column marks of
    /// the words before it (at most [`GRID_HISTORY`]).
    word_marks: Vec<GridMark>,
    grid_history: Vec<GridMark>,
    pending: Vec<FilterOutput>,
    pub stats: ReaderStats,
}

/// Two-column marks kept from earlier words for the cell grid (it looks at the nearest two).
const GRID_HISTORY: usize = 4;

/// One event into the bin being filled (`acc`, `2 * cells` counts and a sink after them, and the
/// first `touched_len` of `touched`); whether the event fell outside the sensor or the mask. No
/// branch depends on the event: a masked event (about half of them, at random) adds to the sink,
/// which is never read, and a cell's first event moves `touched_len` on (at most every cell is
/// touched, so it stays inside `touched`, which has room for one more).
#[inline(always)]
fn scatter(
    map: &PoolMap,
    cells: u32,
    acc: &mut [u16],
    touched: &mut [u32],
    touched_len: &mut usize,
    e: &Event,
) -> bool {
    // `select_unpredictable`: LLVM's x86 pass that turns selects in loops into branches did so
    // here once the speed estimator's count left this loop (2026-12-02: the reader ~14% slower)
    let cell = map.cell_or_max(e.x, e.y);
    let masked = cell == u32::MAX;
    let i = select_unpredictable(masked, 2 * cells, (e.polarity.index() as u32 * cells).wrapping_add(cell));
    let a = acc[i as usize];
    touched[*touched_len] = i;
    *touched_len += usize::from((a == 0) & !masked);
    acc[i as usize] = select_unpredictable(a == u16::MAX, a, a.wrapping_add(1));
    masked
}

impl<'m, S: WindowClassifier, C: WindowClassifier> StreamReader<'m, S, C> {
    pub fn new(
        cfg: ReaderConfig,
        resolution: Resolution,
        segmenter: &'m S,
        classifier: &'m C,
        speller: &'m Speller,
    ) -> Result<StreamReader<'m, S, C>> {
        cfg.validate()?;
        let map = PoolMap::new(resolution, cfg.labeler.pool, Some(&cfg.labeler.active_cols))?;
        let cells = map.output.pixels();
        let frames = cfg.labeler.frames;
        let estimator = match cfg.timing {
            Timing::Estimated { .. } => Some(SpeedEstimator::new(cfg.estimator.clone(), resolution)?),
            Timing::Given { .. } | Timing::Paper => None,
        };
        let speed_mm_s = cfg.initial_speed_mm_s();
        let reference = cfg.labeler.reference_speed_mm_s;
        let denoiser = match cfg.denoise {
            Some(settings) => {
                Some(encoders::denoise::BackgroundActivityFilter::new(resolution, settings).map_err(|why| {
                    Error::Setting { name: "denoise", value: why, expected: "a background-activity filter's settings" }
                })?)
            }
            None => None,
        };
        Ok(StreamReader {
            bin_us: cfg.labeler.bin_us(speed_mm_s.unwrap_or(reference)),
            filter: TemporalFilter::new(&cfg.scaled_filter(speed_mm_s.unwrap_or(reference))),
            speed_mm_s,
            estimator,
            recent_mm_s: Vec::with_capacity(3),
            recent_head: 0,
            wanted_mm_s: None,
            held: Vec::new(),
            denoiser,
            frames,
            cells,
            map,
            ring: Vec::with_capacity(frames),
            ring_end_us: Vec::with_capacity(frames),
            head: 0,
            acc: vec![0; 2 * cells + 1],
            touched: vec![0; 2 * cells + 1],
            touched_len: 0,
            bin_start: None,
            nonempty: 0,
            last_t: i64::MIN,
            cfg,
            segmenter_state: segmenter.new_state(),
            classifier_state: classifier.new_state(),
            segmenter,
            classifier,
            speller,
            word: Vec::new(),
            word_given: 0,
            word_marks: Vec::new(),
            grid_history: Vec::new(),
            pending: Vec::new(),
            stats: ReaderStats { speed_mm_s, ..ReaderStats::default() },
        })
    }

    /// Bytes the reader holds (its window, the bin being filled, the open segment and word, the
    /// speed estimator's window and any events held for its first estimate): what bounds its
    /// memory on an endless stream.
    pub fn memory_bytes(&self) -> usize {
        let cell = std::mem::size_of::<Cell>();
        self.ring.iter().map(|b| b.capacity() * cell).sum::<usize>()
            + self.ring_end_us.capacity() * 8
            + self.acc.capacity() * 2
            + self.touched.capacity() * 4
            + self.word.iter().map(|c| std::mem::size_of::<ReadChar>() + c.probs.capacity() * 4).sum::<usize>()
            + self.pending.capacity() * std::mem::size_of::<FilterOutput>()
            + (self.word_marks.capacity() + self.grid_history.capacity()) * std::mem::size_of::<GridMark>()
            + self.estimator.as_ref().map_or(0, SpeedEstimator::memory_bytes)
            + self.held.capacity() * std::mem::size_of::<Event>()
            + self.denoiser.as_ref().map_or(0, encoders::denoise::BackgroundActivityFilter::memory_bytes)
    }

    /// The frame (bin) length at the speed being read at.
    pub fn bin_us(&self) -> i64 {
        self.bin_us
    }

    /// The speed being read at (`None` while waiting for the first estimate).
    pub fn speed_mm_s(&self) -> Option<f64> {
        self.speed_mm_s
    }

    /// The estimator's latest estimate (with [`Timing::Estimated`]).
    pub fn last_estimate(&self) -> Option<SpeedEstimate> {
        self.estimator.as_ref().and_then(SpeedEstimator::last)
    }

    /// This stream's state of the segmentation network and of the classifier.
    pub fn states(&self) -> (&S::State, &C::State) {
        (&self.segmenter_state, &self.classifier_state)
    }

    /// The states, once the stream is read.
    pub fn into_states(self) -> (S::State, C::State) {
        (self.segmenter_state, self.classifier_state)
    }

    /// Hands in one event; what it completes is appended to `out`. Events must come in time
    /// order (the `event` index in the error is the count handed in so far).
    pub fn push(&mut self, e: &Event, out: &mut Vec<ReadOutput>) -> Result<()> {
        if e.t_us < self.last_t {
            return Err(Error::OutOfOrder { index: self.stats.events, t_us: e.t_us, previous_t_us: self.last_t });
        }
        self.last_t = e.t_us;
        self.stats.events += 1;
        if self.denoiser.as_mut().is_some_and(|d| !d.retain(e)) {
            self.stats.events_denoised += 1;
            return Ok(());
        }
        if let Some(est) = self.estimator.as_mut() {
            est.push(e);
            if est.due(e.t_us)
                && let Some(x) = est.update(e.t_us)
            {
                self.estimated(x);
            }
        }
        if self.speed_mm_s.is_none() {
            self.held.push(*e);
            let span_us = e.t_us - self.held[0].t_us;
            if self.wanted_mm_s.is_none()
                && (span_us as f64) < self.cfg.hold_ms * 1e3
                && self.held.len() < MAX_HELD_EVENTS
            {
                return Ok(());
            }
            return self.release_held(out);
        }
        self.bin_event(e, out)
    }

    /// Starts reading at the first estimate (or, without one, at the reference speed) and reads
    /// the events held until then.
    fn release_held(&mut self, out: &mut Vec<ReadOutput>) -> Result<()> {
        let speed = self.wanted_mm_s.unwrap_or(self.cfg.labeler.reference_speed_mm_s);
        self.set_speed(speed);
        for e in std::mem::take(&mut self.held) {
            self.bin_event(&e, out)?;
        }
        Ok(())
    }

    /// An estimate: the median of the last three is the speed to read at.
    fn estimated(&mut self, x: SpeedEstimate) {
        self.stats.speed_estimates += 1;
        if self.recent_mm_s.len() < 3 {
            self.recent_mm_s.push(x.speed_mm_s);
        } else {
            self.recent_mm_s[self.recent_head] = x.speed_mm_s;
            self.recent_head = (self.recent_head + 1) % 3;
        }
        let mut r = self.recent_mm_s.clone();
        r.sort_by(f64::total_cmp);
        self.wanted_mm_s = Some(if r.len() == 2 { 0.5 * (r[0] + r[1]) } else { r[r.len() / 2] });
    }

    fn set_speed(&mut self, speed_mm_s: f64) {
        if self.speed_mm_s.is_some() {
            self.stats.speed_changes += 1;
        }
        self.speed_mm_s = Some(speed_mm_s);
        self.stats.speed_mm_s = Some(speed_mm_s);
        self.bin_us = self.cfg.labeler.bin_us(speed_mm_s);
        self.filter.set_durations(&self.cfg.scaled_filter(speed_mm_s));
    }

    /// At a bin boundary: moves to the wanted speed when it is far enough from the current one.
    fn retune(&mut self) {
        if let (Some(now), Some(want)) = (self.speed_mm_s, self.wanted_mm_s)
            && (want / now - 1.0).abs() > self.cfg.retune_fraction
        {
            self.set_speed(want);
        }
    }

    /// One event into the bin being filled.
    fn bin_event(&mut self, e: &Event, out: &mut Vec<ReadOutput>) -> Result<()> {
        let start = *self.bin_start.get_or_insert(e.t_us);
        if e.t_us >= start + self.bin_us {
            self.advance_to(e.t_us, out)?;
        }
        let masked = scatter(&self.map, self.cells as u32, &mut self.acc, &mut self.touched, &mut self.touched_len, e);
        self.stats.events_masked += u64::from(masked);
        Ok(())
    }

    /// Hands in events in time order (a chunk of a stream): [`push`](Self::push) for each, with
    /// the events inside one bin (and before the estimator's next update) accumulated in a tight
    /// loop.
    pub fn push_all(&mut self, events: &[Event], out: &mut Vec<ReadOutput>) -> Result<()> {
        if self.denoiser.is_some() {
            // every event through the filter: no run of a bin binned at once
            return events.iter().try_for_each(|e| self.push(e, out));
        }
        let mut k = 0;
        while k < events.len() {
            self.push(&events[k], out)?;
            k += 1;
            if self.speed_mm_s.is_none() {
                continue;
            }
            let end = self.bin_start.map_or(i64::MIN, |s| s + self.bin_us);
            let due = self.estimator.as_ref().map_or(i64::MAX, |s| s.next_update_us().unwrap_or(i64::MIN));
            let cells = self.cells as u32;
            let (mut last, mut masked, start) = (self.last_t, 0u64, k);
            let (map, acc, touched, mut n_touched) =
                (&self.map, &mut self.acc[..], &mut self.touched[..], self.touched_len);
            while k < events.len() {
                let e = &events[k];
                if e.t_us >= end || e.t_us < last || e.t_us >= due {
                    break;
                }
                last = e.t_us;
                masked += u64::from(scatter(map, cells, acc, touched, &mut n_touched, e));
                k += 1;
            }
            // the run has no update due inside it
            if let Some(s) = self.estimator.as_mut() {
                s.push_run(&events[start..k]);
            }
            self.last_t = last;
            self.touched_len = n_touched;
            self.stats.events += (k - start) as u64;
            self.stats.events_masked += masked;
        }
        Ok(())
    }

    /// Closes every bin that ends at or before `t_us` (each a frame).
    pub fn advance_to(&mut self, t_us: i64, out: &mut Vec<ReadOutput>) -> Result<()> {
        let Some(mut start) = self.bin_start else { return Ok(()) };
        while t_us >= start + self.bin_us {
            self.close_bin(start + self.bin_us, out)?;
            start += self.bin_us;
            self.retune();
            // a long silence: once the window is empty, skip to the bin holding `t_us` (the
            // filter still sees the time pass)
            if self.nonempty == 0 && self.touched_len == 0 && t_us >= start + self.bin_us {
                let skip = (t_us - start) / self.bin_us;
                let target = start + skip * self.bin_us;
                // the frames at which the filter closes a segment or a word, on the frame grid
                while let Some(d) = self.filter.next_deadline().filter(|&d| d <= target) {
                    let frame = start + (d - start + self.bin_us - 1).div_euclid(self.bin_us) * self.bin_us;
                    self.filter.tick(frame.max(d), &mut self.pending);
                }
                self.filter.tick(target, &mut self.pending);
                self.stats.frames += skip as u64;
                self.stats.frames_empty += skip as u64;
                start = target;
                self.drain(out);
            }
        }
        self.bin_start = Some(start);
        Ok(())
    }

    /// The stream has ended: events still held are read, the bin being filled closes and the
    /// open character and word are given out.
    pub fn finish(&mut self, out: &mut Vec<ReadOutput>) -> Result<()> {
        if self.speed_mm_s.is_none() && !self.held.is_empty() {
            self.release_held(out)?;
        }
        if let Some(start) = self.bin_start {
            self.close_bin(start + self.bin_us, out)?;
            self.bin_start = Some(start + self.bin_us);
            self.filter.finish(start + self.bin_us, &mut self.pending);
        }
        self.drain(out);
        if !self.word.is_empty() {
            self.end_word(out);
        }
        Ok(())
    }

    fn close_bin(&mut self, t_end_us: i64, out: &mut Vec<ReadOutput>) -> Result<()> {
        let mut bin = if self.ring.len() == self.frames {
            let old = std::mem::take(&mut self.ring[self.head]);
            self.nonempty -= usize::from(!old.is_empty());
            old
        } else {
            Vec::new()
        };
        bin.clear();
        for &i in &self.touched[..self.touched_len] {
            bin.push(Cell { input: i, count: f32::from(std::mem::take(&mut self.acc[i as usize])) });
        }
        self.touched_len = 0;
        self.nonempty += usize::from(!bin.is_empty());
        if self.ring.len() < self.frames {
            self.ring.push(bin);
            self.ring_end_us.push(t_end_us);
        } else {
            self.ring[self.head] = bin;
            self.ring_end_us[self.head] = t_end_us;
            self.head = (self.head + 1) % self.frames;
        }
        self.stats.frames += 1;
        if self.ring.len() == self.frames {
            self.frame(t_end_us)?;
        }
        self.drain(out);
        Ok(())
    }

    fn frame(&mut self, t_end_us: i64) -> Result<()> {
        if self.nonempty == 0 {
            self.stats.frames_empty += 1;
            self.filter.tick(t_end_us, &mut self.pending);
            return Ok(());
        }
        let (a, b) = self.ring.split_at(self.head);
        let (ea, eb) = self.ring_end_us.split_at(self.head);
        let window = Window {
            t_end_us,
            bin_us: self.bin_us,
            height: self.map.output.height as usize,
            width: self.map.output.width as usize,
            bins: [b, a],
            ends_us: [eb, ea],
        };
        self.stats.segmenter_calls += 1;
        let seg = self.segmenter.classify(&mut self.segmenter_state, &window)?;
        let present = seg.get(1).copied().unwrap_or(0.0);
        if present <= self.cfg.present_threshold {
            self.filter.tick(t_end_us, &mut self.pending);
            return Ok(());
        }
        self.stats.classifier_calls += 1;
        let probs = self.classifier.classify(&mut self.classifier_state, &window)?;
        let (k, &p) = probs
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(&a.0)))
            .ok_or(Error::Mismatch { what: "the character classifier gave no probabilities" })?;
        let letter = crate::words::Alphabet::of_classes(probs.len()).symbol(k);
        self.filter.detect(&Detection { t_us: t_end_us, letter, confidence: p }, Some(&probs), &mut self.pending);
        Ok(())
    }

    fn drain(&mut self, out: &mut Vec<ReadOutput>) {
        for o in std::mem::take(&mut self.pending) {
            match o {
                FilterOutput::Char { mut c, new_word } => {
                    c.speed_mm_s = self.speed_mm_s;
                    if new_word && !self.word.is_empty() {
                        self.end_word(out);
                    }
                    self.stats.characters += 1;
                    self.word_marks.push(self.grid_mark(&c));
                    self.word.push(c);
                    self.give_chars(out, false);
                    if self.word.len() >= self.cfg.max_word_chars.max(1) {
                        self.end_word(out);
                    }
                }
                FilterOutput::WordEnd => {
                    if !self.word.is_empty() {
                        self.end_word(out);
                    }
                }
            }
        }
    }

    /// Where character `c` passed, for the cell grid: its segment's middle, and for a cell of
    /// one column the labeler's shift taken off (the classifiers' windows of a lone column end
    /// that much later than a two-column cell's), so that every mark stands at its cell's last
    /// column.
    fn grid_mark(&self, c: &ReadChar) -> GridMark {
        let cell = BrailleCell::from_unicode(c.letter).unwrap_or(BrailleCell::EMPTY);
        let middle_us = (c.t_start_us + c.t_end_us) / 2;
        let shift_us = match (Column::of(cell), c.speed_mm_s) {
            (Some(_), Some(v)) if v > 0.0 => {
                (self.cfg.labeler.single_column_shift_ms * 1e3 * self.cfg.labeler.reference_speed_mm_s / v) as i64
            }
            _ => 0,
        };
        GridMark { t_us: middle_us - shift_us, two_columns: cell.two_columns(), speed_mm_s: c.speed_mm_s }
    }

    /// Gives out the word's characters not yet given: a one-column cell once a character follows
    /// it (or, with `all`, at the word's end), placed on the cell grid first.
    fn give_chars(&mut self, out: &mut Vec<ReadOutput>, all: bool) {
        while self.word_given < self.word.len() {
            let i = self.word_given;
            let cell = BrailleCell::from_unicode(self.word[i].letter);
            let one_column = cell.and_then(Column::of);
            if let (Some(grid), Some(cell), Some(_)) = (&self.cfg.cell_grid, cell, one_column) {
                if i + 1 == self.word.len() && !all {
                    return;
                }
                let n = self.grid_history.len();
                let mut marks = Vec::with_capacity(n + self.word_marks.len());
                marks.extend_from_slice(&self.grid_history);
                marks.extend_from_slice(&self.word_marks);
                if let Some(column) = grid.column_at(&marks, n + i) {
                    let c = &mut self.word[i];
                    c.letter = column.holding(cell).unicode();
                    column.place_probs(&mut c.probs);
                }
            }
            out.push(ReadOutput::Char(self.word[self.word_given].clone()));
            self.word_given += 1;
        }
    }

    fn end_word(&mut self, out: &mut Vec<ReadOutput>) {
        self.give_chars(out, true);
        self.word_given = 0;
        let two = self.word_marks.drain(..).filter(|m| m.two_columns);
        self.grid_history.extend(two);
        let extra = self.grid_history.len().saturating_sub(GRID_HISTORY);
        self.grid_history.drain(..extra);
        let chars = std::mem::take(&mut self.word);
        let raw: String = chars.iter().map(|c| c.letter).collect();
        let text = self.speller.correct(&chars);
        self.stats.words += 1;
        out.push(ReadOutput::Word(ReadWord { text, raw, chars }));
    }
}

/// What [`read_all`] gives: the words, the counters and each model's state at the end.
pub struct ReadAll<S, C> {
    pub words: Vec<ReadWord>,
    pub stats: ReaderStats,
    pub segmenter: S,
    pub classifier: C,
}

/// Reads a whole stream of events (in time order): the words.
pub fn read_all<S: WindowClassifier, C: WindowClassifier>(
    events: &[Event],
    cfg: ReaderConfig,
    resolution: Resolution,
    segmenter: &S,
    classifier: &C,
    speller: &Speller,
) -> Result<ReadAll<S::State, C::State>> {
    let mut r = StreamReader::new(cfg, resolution, segmenter, classifier, speller)?;
    let mut out = Vec::new();
    let mut words = Vec::new();
    let mut keep = |out: &mut Vec<ReadOutput>| {
        words.extend(out.drain(..).filter_map(|o| match o {
            ReadOutput::Word(w) => Some(w),
            ReadOutput::Char(_) => None,
        }))
    };
    r.push_all(events, &mut out)?;
    keep(&mut out);
    r.finish(&mut out)?;
    keep(&mut out);
    let stats = r.stats.clone();
    let (segmenter, classifier) = r.into_states();
    Ok(ReadAll { words, stats, segmenter, classifier })
}

#[cfg(test)]
mod tests {
    use super::*;
    use encoders::Polarity;

    #[test]
    fn an_operating_point_keeps_its_threshold_as_written_through_a_json_value() {
        let p = OperatingPoint { present_threshold: 0.95, ..OperatingPoint::PAPER };
        let v = serde_json::to_value(&p).unwrap();
        assert_eq!(v["present_threshold"].as_f64(), Some(0.95));
        let back: OperatingPoint = serde_json::from_value(v).unwrap();
        assert_eq!(back, p);
        assert_eq!(f32_as_printed(0.3), 0.3);
    }

    /// A segmenter that sees a character when the window holds at least `min` events, and a
    /// classifier that reads the letter from the newest non-empty bin's first column (A + col % 26).
    struct Count(f32);
    impl WindowClassifier for Count {
        type State = ();
        fn new_state(&self) {}
        fn classify(&self, _: &mut (), w: &Window) -> Result<Vec<f32>> {
            let n: f32 = w.bins().flat_map(|b| b.iter().map(|c| c.count)).sum();
            Ok(if n >= self.0 { vec![0.0, 1.0] } else { vec![1.0, 0.0] })
        }
    }
    /// The pooled column of the newest non-empty bin's first cell (0 for an empty window).
    fn newest_col(w: &Window) -> usize {
        w.bins().filter(|b| !b.is_empty()).last().map_or(0, |b| b[0].input as usize % w.width)
    }

    struct Column;
    impl WindowClassifier for Column {
        type State = ();
        fn new_state(&self) {}
        fn classify(&self, _: &mut (), w: &Window) -> Result<Vec<f32>> {
            let mut p = vec![0.0; 26];
            p[newest_col(w) % 26] = 1.0;
            Ok(p)
        }
    }

    /// Events at pooled column `col` (pixel 4 col) every 5 ms over `[from, to)` ms.
    fn burst(col: u16, from_ms: i64, to_ms: i64) -> Vec<Event> {
        (from_ms..to_ms)
            .step_by(5)
            .map(|t| Event { t_us: t * 1000, x: 4 * col, y: 200, polarity: Polarity::On })
            .collect()
    }

    fn read(events: Vec<Event>, cfg: ReaderConfig) -> (Vec<ReadWord>, ReaderStats) {
        let speller = Speller::new(Spell::None);
        let r = read_all(&events, cfg, Resolution::DVXPLORER, &Count(1.0), &Column, &speller).unwrap();
        (r.words, r.stats)
    }

    #[test]
    fn bursts_become_letters_and_silences_words() {
        // pooled columns 20 + k read as letter (20 + k) % 26: U, V, W...; 8 mm/s, 10 ms frames
        let mut ev = burst(20, 0, 100); // U
        ev.extend(burst(21, 400, 500)); // V, 300 ms later: same word
        ev.extend(burst(22, 2_000, 2_100)); // W, after more than 1 s of silence: a new word
        let (words, stats) = read(ev, ReaderConfig::at_speed(8.0));
        let text: Vec<&str> = words.iter().map(|w| w.raw.as_str()).collect();
        assert_eq!(text, ["UV", "W"]);
        assert!(stats.frames_empty > 0 && stats.segmenter_calls > 0);
        // a character registers once its segment has ended: after its last detection, before the
        // next burst
        let u = &words[0].chars[0];
        assert_eq!(u.t_registered_us, u.t_end_us + 70_000, "{u:?}");
        assert!(u.t_registered_us < 400_000, "{u:?}");
    }

    #[test]
    fn the_denoiser_drops_lone_events_before_the_reader_sees_them() {
        // lone events 1.5 s apart: each a letter to this segmenter without the filter
        let lone: Vec<Event> = (0..5)
            .map(|k| Event { t_us: k * 1_500_000 + 1_000, x: 4 * (20 + k as u16), y: 200, polarity: Polarity::On })
            .collect();
        assert!(!read(lone.clone(), ReaderConfig::at_speed(8.0)).0.is_empty());
        let cfg = ReaderConfig {
            denoise: Some(encoders::denoise::NoiseFilterSettings::DV_LAB),
            ..ReaderConfig::at_speed(8.0)
        };
        let (words, stats) = read(lone, cfg.clone());
        assert!(words.is_empty() && (stats.events, stats.events_denoised) == (5, 5), "{stats:?}");
        // a contact's events come in neighbouring pixels: pairs 10 us apart every 5 ms pass where
        // the second of a pair follows the first; the first follows the last pair's second 5 ms
        // later, outside the 2 ms window, and is dropped
        let pairs: Vec<Event> = [burst(20, 0, 100), burst(22, 2_000, 2_100)]
            .concat()
            .into_iter()
            .flat_map(|e| [e, Event { t_us: e.t_us + 10, x: e.x + 1, ..e }])
            .collect();
        let (words, stats) = read(pairs.clone(), cfg);
        let text = |words: &[ReadWord]| words.iter().map(|w| w.raw.clone()).collect::<Vec<_>>();
        assert_eq!(text(&words), ["U", "W"], "{stats:?}");
        assert_eq!((stats.events, stats.events_denoised), (80, 40));
        assert_eq!(text(&read(pairs, ReaderConfig::at_speed(8.0)).0), ["U", "W"]);
    }

    /// A cell classifier: pooled column 20 reads ⠉ (dots 1 and 4), any other ⠁ (dot 1, a cell of
    /// one column), with a little probability on ⠈ (dot 4, its twin in the right column).
    struct Cells;
    impl WindowClassifier for Cells {
        type State = ();
        fn new_state(&self) {}
        fn classify(&self, _: &mut (), w: &Window) -> Result<Vec<f32>> {
            let mut p = vec![0.0; 63];
            if newest_col(w) == 20 {
                p[0b001_001 - 1] = 1.0;
            } else {
                (p[0], p[0b001_000 - 1]) = (0.75, 0.25);
            }
            Ok(p)
        }
    }

    #[test]
    fn a_cell_of_one_column_is_placed_on_the_grid_its_neighbours_draw() {
        // at 8 mm/s a cell spacing (6 mm) is 750 ms and the columns 2.5 mm (312 ms) apart. A burst
        // that follows the stream's first 200 ms and precedes more events is detected from 10 ms
        // after its start until its window has passed: its segment's middle is 150 ms after its
        // start, and a lone column's mark the labeler's 280 ms before that. A lone column a whole
        // spacing from ⠉'s right column is ⠈, one a dot spacing short of that ⠁. A burst at 0 ms
        // and one at 6 s, words of their own, frame the row.
        let speller = Speller::new(Spell::None);
        let row = |lone_ms: i64| {
            let mut ev = burst(23, 0, 100);
            ev.extend(burst(20, 2_000, 2_100));
            ev.extend(burst(21, lone_ms, lone_ms + 100));
            ev.extend(burst(23, 6_000, 6_100));
            ev
        };
        let (right_ms, left_ms) = (2_000 + 280 + 750, 2_000 + 280 + 750 - 312);
        for (lone_ms, want, p_left, p_right) in [(right_ms, '⠈', 0.0f32, 1.0f32), (left_ms, '⠁', 1.0, 0.0)] {
            let mut r =
                StreamReader::new(ReaderConfig::at_speed(8.0), Resolution::DVXPLORER, &Count(1.0), &Cells, &speller)
                    .unwrap();
            let mut out = Vec::new();
            r.push_all(&row(lone_ms), &mut out).unwrap();
            r.finish(&mut out).unwrap();
            let chars: String =
                out.iter().filter_map(|o| if let ReadOutput::Char(c) = o { Some(c.letter) } else { None }).collect();
            let words: Vec<&ReadWord> =
                out.iter().filter_map(|o| if let ReadOutput::Word(w) = o { Some(w) } else { None }).collect();
            // the framing words are lone columns with no two-column neighbour in reach: as read
            let raw: Vec<&str> = words.iter().map(|w| w.raw.as_str()).collect();
            assert_eq!(raw, ["⠁", &format!("⠉{want}"), "⠁"], "lone column at {lone_ms} ms");
            // the characters given out are the words' (placed)
            assert_eq!(chars, raw.concat());
            let lone = &words[1].chars[1];
            assert_eq!((lone.probs[0], lone.probs[7]), (p_left, p_right));
        }
        // without the grid the classifier's column stands
        let cfg = ReaderConfig { cell_grid: None, ..ReaderConfig::at_speed(8.0) };
        let r = read_all(&row(right_ms), cfg, Resolution::DVXPLORER, &Count(1.0), &Cells, &speller).unwrap();
        assert_eq!(r.words[1].raw, "⠉⠁");
    }

    #[test]
    fn durations_scale_with_speed() {
        // at 32 mm/s frames are 2.5 ms, windows 50 ms and the word gap 250 ms: 340 ms of silence
        // between bursts splits words; at 8 mm/s it does not
        let mut ev = burst(20, 0, 60);
        ev.extend(burst(21, 400, 460));
        let (words, _) = read(ev.clone(), ReaderConfig::at_speed(32.0));
        assert_eq!(words.iter().map(|w| w.raw.as_str()).collect::<Vec<_>>(), ["U", "V"]);
        let (words, _) = read(ev, ReaderConfig::at_speed(8.0));
        assert_eq!(words.iter().map(|w| w.raw.as_str()).collect::<Vec<_>>(), ["UV"]);
    }

    #[test]
    fn events_out_of_order_are_an_error_and_masked_columns_are_dropped() {
        let mut ev = burst(20, 0, 100);
        ev.push(Event { t_us: 50_000, x: 80, y: 10, polarity: Polarity::Off });
        let speller = Speller::new(Spell::None);
        let e = read_all(&ev, ReaderConfig::at_speed(8.0), Resolution::DVXPLORER, &Count(1.0), &Column, &speller)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("event 20") && e.contains("back in time"), "{e}");
        let (words, stats) = read(burst(5, 0, 100), ReaderConfig::at_speed(8.0));
        assert!(words.is_empty());
        assert_eq!(stats.events_masked, 20);
    }

    #[test]
    fn an_hour_of_stream_is_read_with_bounded_memory() {
        // every 600 ms a 100 ms burst (letters U..Y by column), a word of five, then 1.5 s of
        // silence; an hour of it, handed in a chunk of a second at a time as a live sensor would
        let speller = Speller::new(Spell::None);
        let mut r =
            StreamReader::new(ReaderConfig::at_speed(8.0), Resolution::DVXPLORER, &Count(1.0), &Column, &speller)
                .unwrap();
        let (mut out, mut words, mut peak, mut chunk) = (Vec::new(), 0usize, 0usize, Vec::new());
        let mut t_ms = 0i64;
        let word_ms = 5 * 600 + 1500;
        let mut letters = 0;
        while t_ms < 3_600_000 {
            let k = (t_ms % word_ms) / 600;
            if k < 5 && t_ms % 600 == 0 {
                chunk.extend(burst(20 + k as u16, t_ms, t_ms + 100));
                letters += 1;
            }
            t_ms += 100;
            if t_ms % 1000 == 0 {
                r.push_all(&chunk, &mut out).unwrap();
                chunk.clear();
                words += out.drain(..).filter(|o| matches!(o, ReadOutput::Word(w) if w.raw == "UVWXY")).count();
                peak = peak.max(r.memory_bytes());
            }
        }
        r.push_all(&chunk, &mut out).unwrap();
        r.finish(&mut out).unwrap();
        words += out.drain(..).filter(|o| matches!(o, ReadOutput::Word(w) if w.raw == "UVWXY")).count();
        assert_eq!(r.stats.characters as usize, letters, "every letter of the hour is read");
        assert_eq!(words, 800, "every word of the hour is read");
        assert!(peak < 300_000, "the reader held {peak} bytes");
    }

    #[test]
    fn streams_read_in_parallel_give_what_they_give_read_one_by_one() {
        let streams: Vec<Vec<Event>> = (0..6u16)
            .map(|s| {
                (0..5i64).flat_map(|k| burst(20 + (s + k as u16) % 7, k * 700 + s as i64 * 13, k * 700 + 120)).collect()
            })
            .collect();
        let one = |ev: &Vec<Event>| read(ev.clone(), ReaderConfig::at_speed(8.0));
        let sequential: Vec<_> = streams.iter().map(one).collect();
        let parallel: Vec<_> = std::thread::scope(|sc| {
            let handles: Vec<_> = streams.iter().map(|ev| sc.spawn(move || one(ev))).collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(sequential, parallel);
        assert!(sequential.iter().all(|(w, _)| w.len() == 1 && w[0].raw.len() == 5), "{sequential:?}");
    }

    #[test]
    fn a_word_without_end_is_given_out_in_pieces() {
        let mut ev = Vec::new();
        for k in 0..10 {
            ev.extend(burst(20 + (k % 3) as u16, k * 600, k * 600 + 100));
        }
        let cfg = ReaderConfig { max_word_chars: 4, ..ReaderConfig::at_speed(8.0) };
        let (words, stats) = read(ev, cfg);
        assert_eq!(words.iter().map(|w| w.raw.as_str()).collect::<Vec<_>>(), ["UVWU", "VWUV", "WU"]);
        assert_eq!(stats.characters, 10);
    }

    /// Events of `events` in masked columns (what `events_masked` counts once each is binned).
    fn masked(events: &[Event]) -> u64 {
        let l = LabelerConfig::default();
        let map = PoolMap::new(Resolution::DVXPLORER, l.pool, Some(&l.active_cols)).unwrap();
        events.iter().filter(|e| map.cell(e.x, e.y).is_none()).count() as u64
    }

    #[test]
    fn events_handed_in_runs_read_as_events_handed_in_one_at_a_time() {
        // `push_all`'s binning loop and the runs it hands the speed estimator, against `push`,
        // on a stream with events off the sensor in some runs (the estimator's slow path)
        let speller = Speller::new(Spell::None);
        let mut ev = crate::speed::tests::moving(32.0, true, 0.05, 1.5, 5);
        for (k, e) in ev.iter_mut().enumerate().filter(|(k, _)| k % 997 < 3) {
            (e.x, e.y) = if k % 2 == 0 { (640, e.y) } else { (e.x, 481) };
        }
        let read = |all: bool| {
            let cfg = ReaderConfig::new(Timing::ESTIMATED);
            let mut r = StreamReader::new(cfg, Resolution::DVXPLORER, &Count(1.0), &Column, &speller).unwrap();
            let mut out = Vec::new();
            if all {
                for chunk in ev.chunks(7_777) {
                    r.push_all(chunk, &mut out).unwrap();
                }
            } else {
                for e in &ev {
                    r.push(e, &mut out).unwrap();
                }
            }
            r.finish(&mut out).unwrap();
            // the estimator's whole state: the events it kept, their weights, its counters
            (r.stats.speed_estimates, format!("{:?}", r.stats), format!("{out:?}"), format!("{:?}", r.estimator))
        };
        let (one, all) = (read(false), read(true));
        assert!(one.0 > 0, "{}", one.1);
        assert_eq!(one, all);
    }

    #[test]
    fn the_reader_reads_at_the_speed_it_estimates_and_loses_no_held_event() {
        let speller = Speller::new(Spell::None);
        for (speed, forward) in [(8.0, true), (32.0, false), (64.0, true)] {
            let ev = crate::speed::tests::moving(speed, forward, 0.05, 1.5, 11);
            let mut r = StreamReader::new(
                ReaderConfig::new(Timing::ESTIMATED),
                Resolution::DVXPLORER,
                &Count(1.0),
                &Column,
                &speller,
            )
            .unwrap();
            let mut out = Vec::new();
            // in chunks, as a live sensor hands them in
            for chunk in ev.chunks(7_777) {
                r.push_all(chunk, &mut out).unwrap();
            }
            let read_at = r.speed_mm_s().unwrap();
            assert!((read_at / speed - 1.0).abs() < 0.06, "{speed} mm/s read at {read_at}");
            let bin = 10_000.0 * 8.0 / speed;
            assert!((r.bin_us() as f64 / bin - 1.0).abs() < 0.06, "{speed} mm/s: {} us bins", r.bin_us());
            r.finish(&mut out).unwrap();
            assert_eq!(r.stats.events, ev.len() as u64);
            assert_eq!(r.stats.events_masked, masked(&ev), "every event held for the first estimate is read");
            assert!(r.stats.speed_estimates > 10, "{:?}", r.stats);
            // characters carry the speed they were read at
            for o in &out {
                if let ReadOutput::Char(c) = o {
                    assert!(c.speed_mm_s.is_some_and(|v| (v / speed - 1.0).abs() < 0.3), "{c:?}");
                }
            }
        }
    }

    #[test]
    fn without_an_estimate_reading_starts_at_the_reference_speed_after_the_hold() {
        // noise alone never gives an estimate: after 1 s of stream held the reader starts at
        // 8 mm/s, and reads every event
        let ev: Vec<Event> = crate::speed::tests::moving(8.0, true, 0.5, 2.0, 3)
            .into_iter()
            .filter(|e| e.polarity == Polarity::Off)
            .collect();
        let speller = Speller::new(Spell::None);
        let cfg = ReaderConfig::new(Timing::ESTIMATED);
        let mut r = StreamReader::new(cfg, Resolution::DVXPLORER, &Count(1e9), &Column, &speller).unwrap();
        let mut out = Vec::new();
        r.push_all(&ev[..ev.len() / 4], &mut out).unwrap();
        assert_eq!(r.speed_mm_s(), None, "still holding");
        r.push_all(&ev[ev.len() / 4..], &mut out).unwrap();
        assert_eq!(r.speed_mm_s(), Some(8.0));
        r.finish(&mut out).unwrap();
        assert_eq!(r.stats.events_masked, masked(&ev));
        assert_eq!(r.stats.speed_estimates, 0);
    }

    #[test]
    fn paper_timing_is_fixed_and_a_hint_starts_reading_at_once() {
        let speller = Speller::new(Spell::None);
        let new =
            |t: Timing| StreamReader::new(ReaderConfig::new(t), Resolution::DVXPLORER, &Count(1.0), &Column, &speller);
        let paper = new(Timing::Paper).unwrap();
        assert_eq!((paper.bin_us(), paper.speed_mm_s()), (10_000, Some(8.0)));
        let hinted = new(Timing::Estimated { hint_mm_s: Some(16.0) }).unwrap();
        assert_eq!((hinted.bin_us(), hinted.speed_mm_s()), (5_000, Some(16.0)));
        assert!(new(Timing::Given { speed_mm_s: -1.0 }).is_err());
        assert!(Timing::from_mode(TimingMode::Given, None).is_err());
        assert_eq!(
            Timing::from_mode(TimingMode::Estimated, Some(3.0)).unwrap(),
            Timing::Estimated { hint_mm_s: Some(3.0) }
        );
        // a paper reader of a 32 mm/s stream keeps 10 ms bins: the paper's protocol
        let ev = crate::speed::tests::moving(32.0, true, 0.05, 1.0, 5);
        let r = read_all(&ev, ReaderConfig::new(Timing::Paper), Resolution::DVXPLORER, &Count(1.0), &Column, &speller)
            .unwrap();
        assert_eq!((r.stats.speed_estimates, r.stats.speed_mm_s), (0, Some(8.0)));
    }

    #[test]
    fn the_window_is_the_labelers_heat_map() {
        // the reader's window equals the labeler's heat map of the same span
        struct Grab;
        impl WindowClassifier for Grab {
            type State = Vec<encoders::heatmap::Heatmap>;
            fn new_state(&self) -> Self::State {
                Vec::new()
            }
            fn classify(&self, grabbed: &mut Self::State, w: &Window) -> Result<Vec<f32>> {
                grabbed.push(w.heatmap());
                Ok(vec![1.0, 0.0])
            }
        }
        let ev: Vec<Event> = (0..4000)
            .map(|k| Event {
                t_us: k * 97,
                x: ((k * 37) % 640) as u16,
                y: ((k * 53) % 480) as u16,
                polarity: if k % 3 == 0 { Polarity::Off } else { Polarity::On },
            })
            .collect();
        let cfg = ReaderConfig::at_speed(8.0);
        let speller = Speller::new(Spell::None);
        let grabbed = read_all(&ev, cfg.clone(), Resolution::DVXPLORER, &Grab, &Column, &speller).unwrap().segmenter;
        assert!(grabbed.len() > 10);
        let l = &cfg.labeler;
        let enc = encoders::heatmap::HeatmapEncoder::new(
            encoders::heatmap::HeatmapConfig::new(Resolution::DVXPLORER)
                .with_pool(l.pool)
                .with_bin_us(l.bin_us(8.0))
                .with_mask_cols(l.active_cols.clone()),
        )
        .unwrap();
        for w in &grabbed {
            let a = ev.partition_point(|e| e.t_us < w.t_start_us);
            let b = ev.partition_point(|e| e.t_us < w.t_end_us());
            assert_eq!(w, &enc.encode(&ev[a..b], w.t_start_us, l.frames));
        }
    }
}
