//! Labelled character windows from simulated scans: what the character classifiers learn from
//! and are tested on (SIMULATED data). Each scan is labelled by the paper's pipeline
//! ([`pipeline::labeling`]); a window takes the letter of the character it stands for in reading
//! order, and only scans whose window count matched the row are used (so no window is given
//! another character's letter). The character count is ground truth: it labels training data and
//! never reaches a reader.

use crate::Progress;
use crate::boards::{EV_WORDS, random_word_rows};
use crate::error::{Error, Result};
use crate::world::World;
use encoders::braille::{Cell, cell_on_board};
use encoders::denoise::NoiseFilterSettings;
use encoders::heatmap::Heatmap;
use learn::data::SpikeSet;
use learn::resnet::ImageSet;
use pipeline::grid::GridMark;
use pipeline::input::CharInput;
use pipeline::labeling::{CharWindow, LabelerConfig, label, window_heatmap};
use pipeline::speed::SpeedEstimatorConfig;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sim::sensor::Sensor;
use sim::{Board, BoardKind, ScanConfig, Setup};

/// Which scan a window came from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ScanId {
    /// The board's name (`SAB`, `RAB`, `text:...`).
    pub board: String,
    pub row: usize,
    pub trial: u64,
}

/// What a scan's windows are labelled with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Task {
    /// The character classifier's: each character's window, labelled with its letter.
    #[default]
    Chars,
    /// The cell classifier's (Unified English Braille and any other six-dot code): each
    /// character's window, labelled with its cell, one of the 63 raised-dot patterns (class
    /// `bits - 1`, named by its Unicode Braille pattern U+2801-U+283F; the blank is the word
    /// space, which has no window). A letter board's letters are their Grade-1 cells.
    Cells,
    /// The segmentation network's: each character's window is "character"; the paper's
    /// negatives are "background": the windows `[t_max - 170 ms, t_max + 10 ms]` and
    /// `[t_max + 340 ms, t_max + 520 ms]` on either side of the character's 350 ms window
    /// (durations at 8 mm/s, scaled with speed; relative to the window's start, which is `t_max`
    /// but for single-column characters, whose window the labeler shifts).
    Segment,
}

impl Task {
    pub fn classes(self) -> Vec<String> {
        match self {
            Task::Chars => (b'A'..=b'Z').map(|c| (c as char).to_string()).collect(),
            Task::Cells => (1..64u8).map(|b| Cell(b).unicode().to_string()).collect(),
            Task::Segment => vec!["background".into(), "character".into()],
        }
    }

    /// The task of a classifier of `n` classes: 63 cells, 2 segmentation, else letters.
    pub fn for_classes(n: usize) -> Task {
        match n {
            63 => Task::Cells,
            2 => Task::Segment,
            _ => Task::Chars,
        }
    }

    /// The class a printed character's window is labelled with (segmentation: "character"), or
    /// `None` when the task has no class for it (a blank; for letters, a cell that is no letter).
    pub fn class_of(self, printed: char) -> Option<usize> {
        match self {
            Task::Chars => class_of(printed),
            Task::Cells => cell_class_of(printed),
            Task::Segment => cell_class_of(printed).map(|_| 1),
        }
    }
}

/// The cell class of a printed character (a letter as its Grade-1 cell, or a Unicode Braille
/// pattern): `bits - 1` of its raised dots; `None` for the blank or anything else.
pub fn cell_class_of(printed: char) -> Option<usize> {
    cell_on_board(printed).filter(|&c| c != Cell::EMPTY).map(|c| c.0 as usize - 1)
}

/// One labelled window.
#[derive(Debug, Clone)]
pub struct CharSample {
    /// The character the window belongs to (for a segmentation negative: the one beside it).
    pub letter: char,
    /// The class in the task's classes (a letter's index; 1 for "character", 0 for background).
    pub class: usize,
    pub map: Heatmap,
    /// Which scan it came from.
    pub scan: ScanId,
    /// Where its character passed, for the cell grid (`pipeline::grid`): the labeler's last peak
    /// and column count, and, for cells, the speed the reader's estimator gives from the scan's
    /// events there (`None` otherwise).
    pub mark: GridMark,
}

/// Which scans to take windows from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharSetSpec {
    pub boards: Vec<BoardKind>,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub trials: u64,
    pub seed: u64,
    #[serde(default)]
    pub task: Task,
    /// Character windows: also the windows shifted by this much either way (at 8 mm/s, scaled
    /// with speed), labelled with the same letter, as a streaming reader meets them on the
    /// frames around the aligned one (0: the paper's aligned windows only).
    #[serde(default)]
    pub jitter_ms: f64,
    /// The simulated world of the scans.
    #[serde(default)]
    pub world: World,
    /// Segmentation sets: every blank cell (word spaces, a pitch or two past the row's ends) is
    /// background as well ([`blank_cell_starts`]); false before 2026-11-25.
    #[serde(default)]
    pub blank_cells: bool,
    /// Scans at several speeds and depths in place of `speed_mm_s` and `depth_mm`, one per trial
    /// ([`Sweep::at`]); `None`: every scan at `speed_mm_s` and `depth_mm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<Sweep>,
}

/// Training scans spread over speeds and depths: trial `k` of a row at speed
/// `speeds_mm_s[k mod S]` and depth `depths_mm[(k + k / S) mod D]`, so that consecutive trials
/// change both and `S * D` trials hold every pairing once (the scans stay as many; each is its
/// own seed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sweep {
    pub speeds_mm_s: Vec<f64>,
    pub depths_mm: Vec<f64>,
    /// The simulator's nuisances, trial `k` at `levels[(k mod S + k / S) mod L]` of the way from
    /// `nominal` (0) to `harsh` (1) ([`sim::Setup::between`]), so that a level meets every
    /// speed. Empty: the world's preset.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub levels: Vec<f64>,
}

impl Sweep {
    /// The speed and depth of trial `trial`.
    pub fn at(&self, trial: u64) -> (f64, f64) {
        let (s, d) = (self.speeds_mm_s.len().max(1) as u64, self.depths_mm.len().max(1) as u64);
        let speed = self.speeds_mm_s.get((trial % s) as usize).copied().unwrap_or(8.0);
        let depth = self.depths_mm.get(((trial + trial / s) % d) as usize).copied().unwrap_or(1.5);
        (speed, depth)
    }

    /// Which of `levels` trial `trial` is at (`None` without levels).
    pub fn level_index(&self, trial: u64) -> Option<usize> {
        let s = self.speeds_mm_s.len().max(1) as u64;
        (!self.levels.is_empty()).then(|| ((trial % s + trial / s) % self.levels.len() as u64) as usize)
    }
}

impl CharSetSpec {
    /// The speed and depth of trial `trial`'s scans.
    pub fn condition(&self, trial: u64) -> (f64, f64) {
        match &self.sweep {
            Some(s) => s.at(trial),
            None => (self.speed_mm_s, self.depth_mm),
        }
    }
}

/// The letter index of the 26 classes (`A` = 0).
pub fn class_of(letter: char) -> Option<usize> {
    letter.is_ascii_uppercase().then(|| (letter as u8 - b'A') as usize)
}

/// Windows of one scan: `(board, row, trial)` with scan seed `scan_seed`.
#[allow(clippy::too_many_arguments)]
pub fn scan_windows(
    board: &Board,
    sensor: &Sensor,
    row: usize,
    trial: u64,
    scan_seed: u64,
    speed_mm_s: f64,
    depth_mm: f64,
    cfg: &LabelerConfig,
    task: Task,
    jitter_ms: f64,
) -> Result<Option<Vec<CharSample>>> {
    let scan = ScanConfig { speed_mm_s, depth_mm, row, seed: scan_seed, ..ScanConfig::default() };
    scan_windows_with(board, sensor, &scan, trial, cfg, task, jitter_ms, false, None)
}

/// [`scan_windows`] of a scan configured in full (a realism preset's kinematics). With
/// `blank_cells`, a segmentation set also takes every blank cell (a word space, and a cell's
/// pitch past either end of the row) as background ([`blank_cell_starts`]); with `denoise`,
/// the scan's events pass that background-activity filter first, as a reader's do.
#[allow(clippy::too_many_arguments)]
pub fn scan_windows_with(
    board: &Board,
    sensor: &Sensor,
    scan: &ScanConfig,
    trial: u64,
    cfg: &LabelerConfig,
    task: Task,
    jitter_ms: f64,
    blank_cells: bool,
    denoise: Option<NoiseFilterSettings>,
) -> Result<Option<Vec<CharSample>>> {
    let mut s = sim::simulate(board, sensor, scan)?;
    denoised(&mut s.events, sensor.camera.resolution, denoise)?;
    let chars: Vec<char> = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).map(|c| c.letter).collect();
    let id = ScanId { board: board.kind.name(), row: scan.row, trial };
    let blank = |windows: &[CharWindow]| blank_cell_starts(&s.truth.characters, windows);
    let blank: Option<&BlankStarts> = if blank_cells { Some(&blank) } else { None };
    label_scan(&s.events, sensor.camera.resolution, scan.speed_mm_s, &chars, cfg, task, jitter_ms, blank, id)
}

/// `events` passed through a background-activity filter with `settings` (none: as they are).
fn denoised(
    events: &mut Vec<encoders::Event>,
    resolution: encoders::Resolution,
    settings: Option<NoiseFilterSettings>,
) -> Result<()> {
    if let Some(settings) = settings {
        encoders::denoise::BackgroundActivityFilter::new(resolution, settings)
            .map_err(|value| Error::Setting {
                name: "denoise",
                value,
                expected: "a background-activity filter's settings",
            })?
            .filter(events);
    }
    Ok(())
}

/// Where a character's window would start over each blank cell of a scan, given the labeler's
/// windows of its lettered cells.
pub type BlankStarts<'a> = dyn Fn(&[CharWindow]) -> Vec<i64> + 'a;

/// The labelled windows of one scan's events (`None` when the labeler's window count is not the
/// number of lettered cells `chars`, in reading order): each character's window (and, with
/// `jitter_ms`, the windows shifted either way), or for segmentation the paper's negatives and
/// background from the rest of the scan; with `blank_starts`, where a character's window would
/// start over each blank cell, those as background too. `speed_mm_s` scales the labeler's
/// durations: the truth's, or a recording's commanded speed.
#[allow(clippy::too_many_arguments)]
pub fn label_scan(
    events: &[encoders::Event],
    resolution: encoders::Resolution,
    speed_mm_s: f64,
    chars: &[char],
    cfg: &LabelerConfig,
    task: Task,
    jitter_ms: f64,
    blank_starts: Option<&BlankStarts>,
    id: ScanId,
) -> Result<Option<Vec<CharSample>>> {
    let l = label(events, resolution, speed_mm_s, chars.len(), cfg)?;
    if !l.count_matched {
        return Ok(None);
    }
    // the speed a reader would estimate from the events, where the cell grid needs it
    let estimates = if task == Task::Cells {
        pipeline::speed::estimates_of(events, &SpeedEstimatorConfig::default(), resolution)?
    } else {
        Vec::new()
    };
    let mut out = Vec::with_capacity(chars.len());
    let scaled = |ms: f64| (ms * 1e3 * cfg.reference_speed_mm_s / speed_mm_s).round() as i64;
    for (k, (w, &letter)) in l.windows.iter().zip(chars).enumerate() {
        let mark = GridMark {
            t_us: w.t_max_us,
            two_columns: w.peaks >= 2,
            speed_mm_s: pipeline::speed::speed_near(&estimates, w.t_max_us, GRID_SPEED_HALF_MS),
        };
        let mut windows = Vec::new();
        match task {
            Task::Chars | Task::Cells => {
                if let Some(class) = task.class_of(letter) {
                    windows.push((class, w.clone()));
                    if jitter_ms > 0.0 {
                        for d in [-jitter_ms, jitter_ms] {
                            let d = scaled(d);
                            windows.push((
                                class,
                                CharWindow { t_start_us: w.t_start_us + d, t_end_us: w.t_end_us + d, ..w.clone() },
                            ));
                        }
                    }
                }
            }
            Task::Segment => {
                let at = |from_ms: f64, to_ms: f64| CharWindow {
                    t_start_us: w.t_start_us + scaled(from_ms),
                    t_end_us: w.t_start_us + scaled(to_ms),
                    ..w.clone()
                };
                windows.push((1, w.clone()));
                windows.push((0, at(-170.0, 10.0)));
                windows.push((0, at(cfg.window_ms - 10.0, cfg.window_ms + 170.0)));
            }
        }
        if task == Task::Segment && k + 1 == l.windows.len() {
            // Beyond the paper: background from the rest of the scan as well (touch-down,
            // lift-off, and between characters, where the second column of one and the first of
            // the next look like a character). Candidates every 50 ms (scaled) at least 170 ms
            // from every character's window; two per character, evenly spread.
            let (t0, t1) = (events.first().map_or(0, |e| e.t_us), events.last().map_or(0, |e| e.t_us));
            let span = scaled(cfg.window_ms);
            let guard = scaled(170.0);
            let mut candidates = Vec::new();
            let mut t = t0;
            while t + span <= t1 {
                if l.windows.iter().all(|c| (c.t_start_us - t).abs() >= guard) {
                    candidates.push(t);
                }
                t += scaled(50.0);
            }
            let want = 2 * l.windows.len();
            let stride = (candidates.len() as f64 / want as f64).max(1.0);
            let mut k = 0.0;
            while (k as usize) < candidates.len() && windows.len() < 3 + want {
                let t = candidates[k as usize];
                windows.push((0, CharWindow { t_start_us: t, t_end_us: t + span, ..w.clone() }));
                k += stride;
            }
            if let Some(blank_starts) = blank_starts {
                for t in blank_starts(&l.windows) {
                    if t >= t0 && t + span <= t1 {
                        windows.push((0, CharWindow { t_start_us: t, t_end_us: t + span, ..w.clone() }));
                    }
                }
            }
        }
        for (class, w) in windows {
            let map = window_heatmap(events, resolution, speed_mm_s, &w, cfg)?;
            out.push(CharSample { letter, class, map, scan: id.clone(), mark });
        }
    }
    Ok(Some(out))
}

/// [`blank_cell_starts`] for a scan with no truth but its printed row (a recording): each blank
/// cell of `text` (a word space, and one and two cells past either end) placed between the
/// windows of the lettered cells around it in proportion to the cells between them (the slide's
/// speed taken as even over a few cells). `windows` are the labeler's, one per lettered cell.
pub fn blank_cell_starts_from_text(text: &str, windows: &[CharWindow]) -> Vec<i64> {
    let cells: Vec<char> = text.chars().collect();
    let lettered: Vec<(f64, f64)> = cells
        .iter()
        .enumerate()
        .filter(|(_, c)| !c.is_whitespace())
        .zip(windows)
        .map(|((i, _), w)| (i as f64, w.t_start_us as f64))
        .collect();
    if lettered.len() < 2 {
        return Vec::new();
    }
    let at = |i: f64| -> f64 {
        // between the lettered cells around i, or from the two nearest at either end
        let k = lettered.partition_point(|p| p.0 < i).clamp(1, lettered.len() - 1);
        let (a, b) = (lettered[k - 1], lettered[k]);
        a.1 + (b.1 - a.1) * (i - a.0) / (b.0 - a.0)
    };
    let (first, last) = (lettered[0].0, lettered[lettered.len() - 1].0);
    let mut blank: Vec<f64> = cells
        .iter()
        .enumerate()
        .filter(|(i, c)| c.is_whitespace() && (first..last).contains(&(*i as f64)))
        .map(|(i, _)| i as f64)
        .collect();
    blank.extend([first - 2.0, first - 1.0, last + 1.0, last + 2.0]);
    blank.into_iter().map(|i| at(i).round() as i64).collect()
}

/// Where a character's window would start over each blank cell of a scan: every word space, and
/// one and two cell pitches past the row's last character and before its first (the flat board a
/// reader meets there). Each is placed from the nearest labelled character's window by the
/// difference of the two cells' passing times in the scan's truth, so the windows sit as the
/// labeler aligns a character's. `windows` are the labeler's, one per lettered cell, in order.
pub fn blank_cell_starts(cells: &[sim::scan::CharacterTruth], windows: &[CharWindow]) -> Vec<i64> {
    let lettered: Vec<(f64, i64)> = cells
        .iter()
        .filter(|c| !c.columns.is_empty())
        .zip(windows)
        .filter_map(|(c, w)| c.t_cell_center_s.map(|t| (t, w.t_start_us)))
        .collect();
    let mut centres: Vec<f64> =
        cells.iter().filter(|c| c.columns.is_empty()).filter_map(|c| c.t_cell_center_s).collect();
    // the cell pitch in time at either end, from the two outermost neighbouring cells
    let times: Vec<f64> = cells.iter().filter_map(|c| c.t_cell_center_s).collect();
    if times.len() >= 2 {
        let (first, second) = (times[0], times[1]);
        let (last, before) = (times[times.len() - 1], times[times.len() - 2]);
        for k in [1.0, 2.0] {
            centres.push(first - k * (second - first));
            centres.push(last + k * (last - before));
        }
    }
    centres
        .into_iter()
        .filter_map(|t| {
            let &(tc, start) = lettered.iter().min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))?;
            Some(start + ((t - tc) * 1e6).round() as i64)
        })
        .collect()
}

/// Every (board, row, trial) of `spec`, in a fixed order, boards printed as `setup` prints.
pub fn scans(spec: &CharSetSpec, setup: &Setup) -> Result<Vec<(Board, usize, u64)>> {
    let mut out = Vec::new();
    for kind in &spec.boards {
        let board = spec.world.board(setup, kind)?;
        for row in 0..board.rows.len() {
            for trial in 0..spec.trials {
                out.push((board.clone(), row, trial));
            }
        }
    }
    Ok(out)
}

/// Windows cropped for one or more model inputs, with where each came from.
#[derive(Debug, Clone, Default)]
pub struct Windows {
    /// One set per input asked for, the same windows in the same order.
    pub sets: Vec<ImageSet>,
    /// Per window: its scan.
    pub origin: Vec<ScanId>,
    /// Per window: where its character passed (`CharSample::mark`).
    pub marks: Vec<GridMark>,
    /// Scans simulated, and those skipped because the labeler's window count was off.
    pub scans: usize,
    pub skipped_scans: usize,
    /// Characters printed on every scan's row (skipped scans included): the windows there would
    /// be had the labeler found every character.
    pub printed: usize,
}

impl Windows {
    /// Accuracy over every printed character, from `right` windows classified correctly: the
    /// characters of skipped scans count as errors.
    pub fn accuracy_all(&self, right: usize) -> f64 {
        if self.printed == 0 { 0.0 } else { right as f64 / self.printed as f64 }
    }
}

/// Windows of `spec`'s scans for one input (see [`build_many`]).
pub fn build(spec: &CharSetSpec, input: &CharInput, progress: &dyn Progress) -> Result<(ImageSet, Windows)> {
    let mut w = build_many(spec, &[input], progress)?;
    let set = w.sets.remove(0);
    Ok((set, w))
}

/// Windows of `spec`'s scans, simulated in parallel and cropped as soon as their scan is done (so
/// memory holds only the crops). Each scan is simulated and labelled once and its windows cropped
/// for every input (which must share one labeler), so all models see the same windows. The same
/// spec gives the same windows, whichever model asks.
pub fn build_many(spec: &CharSetSpec, inputs: &[&CharInput], progress: &dyn Progress) -> Result<Windows> {
    build_many_in(spec, &spec.world.setup(), inputs, progress)
}

/// The first of the models' inputs, which must all label with the same labeler and filter the
/// same way (one set of windows serves them all).
fn first_of_one_labeler<'a>(inputs: &[&'a CharInput]) -> Result<&'a CharInput> {
    let Some(&first) = inputs.first() else {
        return Err(Error::NoInputs);
    };
    if inputs.iter().any(|i| i.labeler != first.labeler || i.denoise != first.denoise) {
        return Err(Error::LabelersDiffer);
    }
    Ok(first)
}

/// [`build_many`] with the world's preset replaced by `setup` (a robustness sweep's nuisance
/// levels), or, when the spec's sweep has nuisance levels, by each trial's level between
/// `nominal` and `harsh` ([`Sweep::levels`]); the world still picks the sensor builds and the
/// scan seeds.
pub fn build_many_in(
    spec: &CharSetSpec,
    setup: &Setup,
    inputs: &[&CharInput],
    progress: &dyn Progress,
) -> Result<Windows> {
    let first = first_of_one_labeler(inputs)?;
    // One setup (its builds and boards) per nuisance level of the sweep, else `setup` alone.
    let levels = spec.sweep.as_ref().map_or(&[][..], |s| &s.levels[..]);
    let setups: Vec<Setup> =
        if levels.is_empty() { vec![setup.clone()] } else { levels.iter().map(|&l| Setup::between(l)).collect() };
    let sensors =
        setups.iter().map(|s| spec.world.sensors_at(s, encoders::Resolution::DVXPLORER)).collect::<Result<Vec<_>>>()?;
    let boards = setups.iter().map(|s| scans(spec, s)).collect::<Result<Vec<_>>>()?;
    let at = |trial: u64| spec.sweep.as_ref().and_then(|s| s.level_index(trial)).unwrap_or(0);
    let list: Vec<(usize, &(Board, usize, u64))> =
        boards[0].iter().enumerate().map(|(k, &(_, _, trial))| (at(trial), &boards[at(trial)][k])).collect();
    let printed = list
        .iter()
        .map(|(_, (board, row, _))| board.rows[*row].chars().filter(|&c| spec.task.class_of(c).is_some()).count())
        .sum();
    progress.start("simulating scans", list.len() as u64);
    let per_scan: Vec<Option<Vec<Kept>>> = list
        .par_iter()
        .map(|&(level, (board, row, trial))| -> Result<_> {
            let w = &spec.world;
            let (speed_mm_s, depth_mm) = spec.condition(*trial);
            let seed = w.scan_seed(spec.seed, &board.kind, *row, *trial, speed_mm_s, depth_mm);
            let sensors = &sensors[level];
            let sensor = &sensors[(*trial % sensors.len() as u64) as usize];
            let scan = setups[level].scan(speed_mm_s, depth_mm, *row, seed);
            let r = scan_windows_with(
                board,
                sensor,
                &scan,
                *trial,
                &first.labeler,
                spec.task,
                spec.jitter_ms,
                spec.blank_cells,
                first.denoise,
            )?;
            progress.inc();
            r.map(|samples| crop_all(samples, inputs)).transpose()
        })
        .collect::<Result<_>>()?;
    progress.finish();
    Ok(gather(per_scan, inputs, printed))
}

/// The estimates a window's speed for the cell grid is the median of: those within this much of
/// its character's last peak (the estimator updates every few ms; the median drops an outlier).
const GRID_SPEED_HALF_MS: f64 = 500.0;

/// A window's class, its crop for each input, its scan and its mark.
type Kept = (usize, Vec<Vec<f32>>, ScanId, GridMark);

fn crop_all(samples: Vec<CharSample>, inputs: &[&CharInput]) -> Result<Vec<Kept>> {
    samples
        .into_iter()
        .map(|s| {
            let crops = inputs.iter().map(|i| Ok(i.crop(&s.map)?.counts)).collect::<Result<_>>()?;
            Ok((s.class, crops, s.scan, s.mark))
        })
        .collect()
}

/// The windows of every scan in order (`None`: a scan the labeler miscounted) as one set per input.
fn gather(per_scan: Vec<Option<Vec<Kept>>>, inputs: &[&CharInput], printed: usize) -> Windows {
    let mut sets: Vec<ImageSet> = inputs.iter().map(|i| ImageSet { shape: i.shape(), ..ImageSet::default() }).collect();
    let (mut origin, mut marks) = (Vec::new(), Vec::new());
    let scans = per_scan.len();
    let skipped_scans = per_scan.iter().filter(|s| s.is_none()).count();
    for (class, crops, scan, mark) in per_scan.into_iter().flatten().flatten() {
        for (set, counts) in sets.iter_mut().zip(crops) {
            set.data.push(counts);
            set.labels.push(class);
        }
        origin.push(scan);
        marks.push(mark);
    }
    Windows { sets, origin, marks, scans, skipped_scans, printed }
}

/// The labelled windows of recorded scans (a lab's recordings folder, docs/recordings.md), as
/// [`build_many`] makes them of simulated ones: each scan labelled by the paper's pipeline with
/// its character count from the manifest's `text` and its durations from the commanded
/// `speed_mm_s` (labels for training and scoring; a reader never gets them), and with
/// `blank_cells` the blank cells placed from the text ([`blank_cell_starts_from_text`]). A scan
/// is read from its file, labelled, cropped and let go: memory holds the crops. A window's
/// [`ScanId`] names the file, with row 0 and the manifest line as its trial.
pub fn recorded_windows(
    rec: &crate::recordings::Recordings,
    scans: &[&crate::recordings::Recording],
    inputs: &[&CharInput],
    task: Task,
    jitter_ms: f64,
    blank_cells: bool,
    progress: &dyn Progress,
) -> Result<Windows> {
    let first = first_of_one_labeler(inputs)?;
    let letters = |r: &crate::recordings::Recording| -> Vec<char> {
        r.text.chars().filter(|c| !c.is_whitespace()).map(|c| c.to_ascii_uppercase()).collect()
    };
    let printed = scans.iter().map(|r| letters(r).iter().filter(|&&c| task.class_of(c).is_some()).count()).sum();
    progress.start("labelling recorded scans", scans.len() as u64);
    let per_scan: Vec<Option<Vec<Kept>>> = scans
        .par_iter()
        .map(|r| -> Result<_> {
            let path = rec.path(r);
            let (info, mut events) = encoders::formats::read_all(&path, &encoders::OpenOptions::default())?;
            let resolution = info.resolution.unwrap_or(encoders::Resolution::DVXPLORER);
            denoised(&mut events, resolution, first.denoise)?;
            let text = r.text.to_uppercase();
            let blank = |windows: &[CharWindow]| blank_cell_starts_from_text(&text, windows);
            let blank: Option<&BlankStarts> = if blank_cells { Some(&blank) } else { None };
            let id = ScanId { board: r.file.display().to_string(), row: 0, trial: r.line };
            let samples =
                label_scan(&events, resolution, r.speed_mm_s, &letters(r), &first.labeler, task, jitter_ms, blank, id)
                    .map_err(|e| e.in_file(&path))?;
            progress.inc();
            samples.map(|samples| crop_all(samples, inputs)).transpose()
        })
        .collect::<Result<_>>()?;
    progress.finish();
    Ok(gather(per_scan, inputs, printed))
}

/// The training protocol's windows, split by whole scans.
#[derive(Debug, Clone)]
pub struct TrainingWindows {
    pub all: ImageSet,
    /// Indices into `all`.
    pub train: Vec<usize>,
    pub val: Vec<usize>,
    pub scans: usize,
    pub skipped_scans: usize,
}

/// Which training scans: the boards' rows and how each is scanned.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrainingScans {
    /// Scans per board row.
    pub trials: u64,
    pub seed: u64,
    /// Rows of random words (beyond the paper: letters with neighbours at the cell spacing, as in
    /// words; the single-letter boards spread their letters over the row).
    pub word_rows: usize,
    /// Rows that hold every letter at every place this many times
    /// ([`crate::boards::training_letter_rows`], the rare letters' share; 0: none).
    pub letter_rows: usize,
    /// Passes of letter strings that hold every ordered pair of letters inside a word
    /// ([`crate::boards::training_pair_rows`], the neighbours a window sees; 0: none; not with
    /// `cells`, whose cell rows are in seeded orders already).
    #[serde(skip_serializing_if = "is_zero")]
    pub pair_rows: usize,
    /// Scans spread over speeds and depths (`None`: the paper's 8 mm/s and 1.5 mm).
    pub sweep: Option<Sweep>,
    /// The boards of a cell reader (UEB): in place of SAB, UN and the letter and word rows,
    /// `letter_rows` times every cell ([`crate::boards::training_cell_rows`]) and `word_rows`
    /// rows of print in this code ([`crate::boards::ueb_training_board`]). `None`: the letters'.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cells: Option<pipeline::code::BrailleCode>,
}

impl TrainingScans {
    /// The training boards, as a summary names them.
    pub fn boards(&self) -> String {
        match self.cells {
            Some(code) => format!(
                "every cell {} times in seeded orders and {} rows of {code} print",
                self.letter_rows, self.word_rows
            ),
            None => format!(
                "SAB and UN, {} rows of random words, all-letters rows {} times{}",
                self.word_rows,
                self.letter_rows,
                match self.pair_rows {
                    0 => String::new(),
                    n => format!(", every letter pair {n} times"),
                }
            ),
        }
    }
}

/// The boards [`training_windows`] scans for `scans`: SAB and UN and the word, all-letters and
/// pair rows (or a cell reader's boards), in that order.
pub fn training_boards(scans: &TrainingScans) -> Result<Vec<BoardKind>> {
    let TrainingScans { seed, word_rows, letter_rows, pair_rows, cells, .. } = *scans;
    Ok(match cells {
        Some(_) if pair_rows > 0 => {
            return Err(Error::Board {
                board: "cell training boards".into(),
                what: "pair rows are the letters' (the cell rows are in seeded orders)".into(),
            });
        }
        Some(code) => training_cell_boards(seed, letter_rows, word_rows, code)?,
        None => {
            let mut boards = vec![BoardKind::Sab, BoardKind::Un];
            if word_rows > 0 {
                let text = random_word_rows(seed ^ 0x5745_5244, word_rows, 22, &EV_WORDS);
                boards.push(BoardKind::Text(text));
            }
            if letter_rows > 0 {
                boards.push(BoardKind::Text(crate::boards::training_letter_rows(letter_rows, 22).text()));
            }
            if pair_rows > 0 {
                boards.push(BoardKind::Text(crate::boards::training_pair_rows(seed ^ 0x5041_4952, pair_rows, 22)));
            }
            boards
        }
    })
}

/// The training protocol's windows in `world` (its training sensor builds): SAB and UN at 8 mm/s
/// and 1.5 mm (the paper's; or over `scans.sweep`), plus the word and all-letters rows of
/// `scans`, split by whole scans (every fifth trial goes to validation when there are five or
/// more), so no scan feeds both.
pub fn training_windows(
    scans: &TrainingScans,
    input: &CharInput,
    task: Task,
    jitter_ms: f64,
    blank_cells: bool,
    world: &World,
    progress: &dyn Progress,
) -> Result<TrainingWindows> {
    let TrainingScans { trials, seed, ref sweep, .. } = *scans;
    let boards = training_boards(scans)?;
    let spec = CharSetSpec {
        boards,
        speed_mm_s: 8.0,
        depth_mm: 1.5,
        trials,
        seed,
        task,
        jitter_ms,
        world: world.clone(),
        blank_cells,
        sweep: sweep.clone(),
    };
    let (all, w) = build(&spec, input, progress)?;
    let (val, train): (Vec<usize>, Vec<usize>) =
        (0..all.len()).partition(|&i| trials >= 5 && w.origin[i].trial % 5 == 4);
    Ok(TrainingWindows { all, train, val, scans: w.scans, skipped_scans: w.skipped_scans })
}

/// A cell reader's training boards: every cell `cell_times` times in seeded orders, and
/// `print_rows` rows of print in `code` (rows of at most 22 cells, as the letters' word rows).
pub fn training_cell_boards(
    seed: u64,
    cell_times: usize,
    print_rows: usize,
    code: pipeline::code::BrailleCode,
) -> Result<Vec<BoardKind>> {
    let mut boards = Vec::new();
    if cell_times > 0 {
        boards.push(BoardKind::Text(crate::boards::training_cell_rows(seed ^ 0x4345_4c4c, cell_times, 22)));
    }
    if print_rows > 0 {
        boards.push(crate::boards::ueb_training_board(seed ^ 0x5545_4221, print_rows, code, 22)?.kind);
    }
    if boards.is_empty() {
        return Err(Error::Board {
            board: "cell training boards".into(),
            what: "no rows: letter_rows and word_rows are 0".into(),
        });
    }
    Ok(boards)
}

/// A lab's training windows from its recordings folder: the `train` scans' windows to train on,
/// the `val` scans' to choose checkpoints by (whole scans, as the simulated split), each scan
/// labelled by the paper's pipeline from the manifest's text and commanded speed
/// ([`recorded_windows`]). The folder must hold scans of both roles.
pub fn recorded_training_windows(
    rec: &crate::recordings::Recordings,
    input: &CharInput,
    task: Task,
    jitter_ms: f64,
    blank_cells: bool,
    progress: &dyn Progress,
) -> Result<TrainingWindows> {
    use crate::recordings::Role;
    let of = |role: Role| -> Result<Windows> {
        let scans: Vec<&crate::recordings::Recording> = rec.role(role).collect();
        if scans.is_empty() {
            return Err(Error::Setting {
                name: "recordings folder",
                value: format!("{}: no {} scans in its manifest", rec.dir.display(), role.name()),
                expected: "scans of role `train` to train on and of role `val` to choose checkpoints by",
            });
        }
        recorded_windows(rec, &scans, &[input], task, jitter_ms, blank_cells, progress)
    };
    let (mut t, mut v) = (of(Role::Train)?, of(Role::Val)?);
    let (mut all, val_set) = (t.sets.remove(0), v.sets.remove(0));
    let train: Vec<usize> = (0..all.len()).collect();
    let val: Vec<usize> = (all.len()..all.len() + val_set.len()).collect();
    all.data.extend(val_set.data);
    all.labels.extend(val_set.labels);
    Ok(TrainingWindows { all, train, val, scans: t.scans + v.scans, skipped_scans: t.skipped_scans + v.skipped_scans })
}

/// The training and validation windows of `tw` as labelled spike trains for an SNN, each dense
/// crop let go as soon as its train is made (the crops and the trains are never all in memory
/// together: the peak is the larger of the two, not their sum).
pub fn snn_sets(input: &CharInput, tw: TrainingWindows, dt_us: i64, task: Task) -> (SpikeSet, SpikeSet) {
    let TrainingWindows { mut all, train, val, .. } = tw;
    let [frames2, h, w] = input.shape();
    let mut convert = |idx: &[usize]| -> SpikeSet {
        let mut trains = Vec::with_capacity(idx.len());
        for chunk in idx.chunks(256) {
            let crops: Vec<Vec<f32>> = chunk.iter().map(|&i| std::mem::take(&mut all.data[i])).collect();
            trains.par_extend(crops.into_par_iter().map(|c| input.spikes(&c, dt_us)));
        }
        SpikeSet {
            n_inputs: 2 * h * w,
            steps: frames2 / 2,
            dt_us,
            classes: task.classes(),
            trains,
            labels: idx.iter().map(|&i| all.labels[i]).collect(),
            dropped_events: 0,
        }
    };
    let (t, v) = (convert(&train), convert(&val));
    (t, v)
}

/// The windows `idx` of `raw` as labelled spike trains for an SNN.
pub fn snn_set(input: &CharInput, raw: &ImageSet, idx: &[usize], dt_us: i64, task: Task) -> SpikeSet {
    let [frames2, h, w] = input.shape();
    SpikeSet {
        n_inputs: 2 * h * w,
        steps: frames2 / 2,
        dt_us,
        classes: task.classes(),
        trains: idx.par_iter().map(|&i| input.spikes(&raw.data[i], dt_us)).collect(),
        labels: idx.iter().map(|&i| raw.labels[i]).collect(),
        dropped_events: 0,
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_labelled_by_their_dots_letters_as_their_grade_1_cells() {
        assert_eq!(Task::Cells.classes().len(), 63);
        assert_eq!(Task::Cells.classes()[0], "⠁");
        assert_eq!(Task::Cells.class_of('⠁'), Some(0));
        assert_eq!(Task::Cells.class_of('A'), Some(0));
        assert_eq!(Task::Cells.class_of('⠿'), Some(62));
        assert_eq!(Task::Cells.class_of(' '), None);
        assert_eq!(Task::Cells.class_of('\u{2800}'), None);
        assert_eq!(Task::Chars.class_of('⠁'), None);
        assert_eq!(Task::Chars.class_of('B'), Some(1));
        assert_eq!(Task::Segment.class_of('⠠'), Some(1));
        assert_eq!(Task::for_classes(63), Task::Cells);
        assert_eq!(Task::for_classes(26), Task::Chars);
    }

    #[test]
    fn a_sweep_walks_every_pairing_of_speed_and_depth() {
        let s = Sweep { speeds_mm_s: vec![8.0, 16.0, 32.0], depths_mm: vec![1.5, 1.0, 0.6], levels: vec![] };
        let at: Vec<(f64, f64)> = (0..10).map(|k| s.at(k)).collect();
        assert_eq!(
            at,
            [
                (8.0, 1.5),
                (16.0, 1.0),
                (32.0, 0.6),
                (8.0, 1.0),
                (16.0, 0.6),
                (32.0, 1.5),
                (8.0, 0.6),
                (16.0, 1.5),
                (32.0, 1.0),
                (8.0, 1.5)
            ]
        );
        // four speeds and three depths: twelve trials hold all twelve pairings, five hold five
        let s = Sweep { speeds_mm_s: vec![8.0, 16.0, 32.0, 48.0], depths_mm: vec![1.5, 1.0, 0.6], levels: vec![] };
        let mut all: Vec<(u64, u64)> = (0..12).map(|k| s.at(k)).map(|(v, d)| (v as u64, (d * 10.0) as u64)).collect();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), 12);
        assert_eq!(s.at(4), (8.0, 0.6));
        assert_eq!(s.level_index(3), None);
    }

    #[test]
    fn nuisance_levels_meet_every_speed() {
        // two levels over four speeds: trial k's level is not fixed by its speed
        let s = Sweep { speeds_mm_s: vec![8.0, 16.0, 32.0, 48.0], depths_mm: vec![1.5], levels: vec![0.0, 1.0] };
        let mut pairs: Vec<(u64, usize)> = (0..8).map(|k| (s.at(k).0 as u64, s.level_index(k).unwrap())).collect();
        pairs.sort();
        pairs.dedup();
        assert_eq!(pairs.len(), 8, "{pairs:?}");
    }

    #[test]
    fn windows_over_levels_come_from_both_presets_and_behind_the_filter() {
        use pipeline::preprocess::{AugmentConfig, Preprocess};
        let input = CharInput {
            labeler: LabelerConfig::default(),
            rows: pipeline::input::LITE_ROWS,
            cols: pipeline::input::LITE_COLS,
            pool: 4,
            preprocess: Preprocess::Norm,
            augment: AugmentConfig::default(),
            band: None,
            denoise: None,
        };
        let spec = |levels: Vec<f64>| CharSetSpec {
            boards: vec![BoardKind::Text("AB".into())],
            speed_mm_s: 32.0,
            depth_mm: 1.5,
            trials: 2,
            seed: 5,
            task: Task::Chars,
            jitter_ms: 0.0,
            world: World::train(sim::Realism::Nominal),
            blank_cells: false,
            sweep: Some(Sweep { speeds_mm_s: vec![32.0], depths_mm: vec![1.5], levels }),
        };
        let counts = |spec: &CharSetSpec, input: &CharInput| -> Vec<f32> {
            let w = build_many(spec, &[input], &()).unwrap();
            w.sets[0].data.iter().map(|d| d.iter().sum()).collect()
        };
        // trial 0 at nominal, trial 1 at harsh: trial 0's windows are nominal's own, trial 1's not
        let nominal = counts(&spec(vec![0.0]), &input);
        let both = counts(&spec(vec![0.0, 1.0]), &input);
        assert_eq!(nominal.len(), 4, "{nominal:?}");
        assert_eq!(both.len(), 4, "{both:?}");
        assert_eq!(nominal[..2], both[..2]);
        assert_ne!(nominal[2..], both[2..]);
        // behind the filter the same windows hold fewer events
        let filtered = CharInput { denoise: Some(NoiseFilterSettings::DV_LAB), ..input.clone() };
        let quiet = counts(&spec(vec![0.0]), &filtered);
        assert_eq!(quiet.len(), 4);
        assert!(quiet.iter().zip(&nominal).all(|(q, n)| q < n), "{quiet:?} against {nominal:?}");
        // models that filter differently cannot share one set of windows
        assert!(matches!(build_many(&spec(vec![0.0]), &[&input, &filtered], &()), Err(Error::LabelersDiffer)));
    }

    #[test]
    fn a_recordings_blank_cells_sit_between_its_lettered_cells() {
        // "AB CD": lettered cells 0, 1, 3, 4 with windows starting 100 us a cell apart
        let w = |t: i64| CharWindow { t_max_us: t, peaks: 2, t_start_us: t, t_end_us: t + 350 };
        let windows = [w(0), w(100), w(300), w(400)];
        // the word space between B and D, then two cells before A and two after D
        assert_eq!(blank_cell_starts_from_text("AB CD", &windows), vec![200, -200, -100, 500, 600]);
        // an uneven slide: the space is placed in proportion between its neighbours
        let uneven = [w(0), w(100), w(500), w(600)];
        assert_eq!(blank_cell_starts_from_text("AB CD", &uneven)[0], 300);
        // one lettered cell gives no pitch to place anything by
        assert!(blank_cell_starts_from_text("A", &[w(0)]).is_empty());
    }

    #[test]
    fn blank_cells_sit_where_a_character_window_would() {
        use sim::scan::{CharacterTruth, ColumnTruth};
        // "AB C" at 0.75 s a cell: the labeler's windows start 0.1 s before each lettered cell's centre
        let cell = |letter: char, index: usize, t: f64| CharacterTruth {
            letter,
            row: 0,
            word: None,
            index,
            x_mm: 6.0 * index as f64,
            y_mm: 0.0,
            dots: Vec::new(),
            t_cell_center_s: Some(t),
            columns: if letter == ' ' {
                Vec::new()
            } else {
                vec![ColumnTruth { column: 0, x_mm: 0.0, t_center_s: None, t_enter_s: None, t_exit_s: None }]
            },
        };
        let cells = [cell('A', 0, 1.0), cell('B', 1, 1.75), cell(' ', 2, 2.5), cell('C', 3, 3.25)];
        let windows: Vec<CharWindow> = [0.9, 1.65, 3.15]
            .map(|t| {
                let t = (t * 1e6) as i64;
                CharWindow { t_max_us: t, peaks: 2, t_start_us: t, t_end_us: t + 350_000 }
            })
            .to_vec();
        let mut got = blank_cell_starts(&cells, &windows);
        got.sort();
        assert_eq!(got, vec![-600_000, 150_000, 2_400_000, 3_900_000, 4_650_000]);
        // no lettered cell, nothing to place a blank by
        assert!(blank_cell_starts(&cells[2..3], &[]).is_empty());
    }
}
