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
use encoders::heatmap::Heatmap;
use learn::data::SpikeSet;
use learn::resnet::ImageSet;
use pipeline::input::CharInput;
use pipeline::labeling::{CharWindow, LabelerConfig, label, window_heatmap};
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
            Task::Segment => vec!["background".into(), "character".into()],
        }
    }
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
    scan_windows_with(board, sensor, &scan, trial, cfg, task, jitter_ms, false)
}

/// [`scan_windows`] of a scan configured in full (a realism preset's kinematics). With
/// `blank_cells`, a segmentation set also takes every blank cell (a word space, and a cell's
/// pitch past either end of the row) as background ([`blank_cell_starts`]).
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
) -> Result<Option<Vec<CharSample>>> {
    let (row, speed_mm_s) = (scan.row, scan.speed_mm_s);
    let s = sim::simulate(board, sensor, scan)?;
    let chars: Vec<char> = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).map(|c| c.letter).collect();
    let l = label(&s.events, sensor.camera.resolution, speed_mm_s, chars.len(), cfg)?;
    if !l.count_matched {
        return Ok(None);
    }
    let mut out = Vec::with_capacity(chars.len());
    let scaled = |ms: f64| (ms * 1e3 * cfg.reference_speed_mm_s / speed_mm_s).round() as i64;
    for (k, (w, &letter)) in l.windows.iter().zip(&chars).enumerate() {
        let mut windows = Vec::new();
        match task {
            Task::Chars => {
                if let Some(class) = class_of(letter) {
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
            let (t0, t1) = (s.events.first().map_or(0, |e| e.t_us), s.events.last().map_or(0, |e| e.t_us));
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
            if blank_cells {
                for t in blank_cell_starts(&s.truth.characters, &l.windows) {
                    if t >= t0 && t + span <= t1 {
                        windows.push((0, CharWindow { t_start_us: t, t_end_us: t + span, ..w.clone() }));
                    }
                }
            }
        }
        for (class, w) in windows {
            let map = window_heatmap(&s.events, sensor.camera.resolution, speed_mm_s, &w, cfg)?;
            out.push(CharSample { letter, class, map, scan: ScanId { board: board.kind.name(), row, trial } });
        }
    }
    Ok(Some(out))
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

/// [`build_many`] with the world's preset replaced by `setup` (a robustness sweep's nuisance
/// levels); the world still picks the sensor builds and the scan seeds.
pub fn build_many_in(
    spec: &CharSetSpec,
    setup: &Setup,
    inputs: &[&CharInput],
    progress: &dyn Progress,
) -> Result<Windows> {
    let Some(first) = inputs.first() else {
        return Err(Error::NoInputs);
    };
    if inputs.iter().any(|i| i.labeler != first.labeler) {
        return Err(Error::LabelersDiffer);
    }
    let sensors = spec.world.sensors_at(setup, encoders::Resolution::DVXPLORER)?;
    let list = scans(spec, setup)?;
    let printed =
        list.iter().map(|(board, row, _)| board.rows[*row].chars().filter(|&c| class_of(c).is_some()).count()).sum();
    progress.start("simulating scans", list.len() as u64);
    type Kept = (usize, Vec<Vec<f32>>, ScanId);
    let per_scan: Vec<Option<Vec<Kept>>> = list
        .par_iter()
        .map(|(board, row, trial)| -> Result<_> {
            let w = &spec.world;
            let seed = w.scan_seed(spec.seed, &board.kind, *row, *trial, spec.speed_mm_s, spec.depth_mm);
            let sensor = &sensors[(*trial % sensors.len() as u64) as usize];
            let scan = setup.scan(spec.speed_mm_s, spec.depth_mm, *row, seed);
            let r = scan_windows_with(
                board,
                sensor,
                &scan,
                *trial,
                &first.labeler,
                spec.task,
                spec.jitter_ms,
                spec.blank_cells,
            )?;
            progress.inc();
            let Some(samples) = r else { return Ok(None) };
            let mut kept = Vec::with_capacity(samples.len());
            for s in samples {
                let crops = inputs.iter().map(|i| Ok(i.crop(&s.map)?.counts)).collect::<Result<_>>()?;
                kept.push((s.class, crops, s.scan));
            }
            Ok(Some(kept))
        })
        .collect::<Result<_>>()?;
    progress.finish();
    let mut sets: Vec<ImageSet> = inputs.iter().map(|i| ImageSet { shape: i.shape(), ..ImageSet::default() }).collect();
    let mut origin = Vec::new();
    let skipped_scans = per_scan.iter().filter(|s| s.is_none()).count();
    for (class, crops, scan) in per_scan.into_iter().flatten().flatten() {
        for (set, counts) in sets.iter_mut().zip(crops) {
            set.data.push(counts);
            set.labels.push(class);
        }
        origin.push(scan);
    }
    Ok(Windows { sets, origin, scans: list.len(), skipped_scans, printed })
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

/// The training protocol's windows in `world` (its training sensor builds): SAB and UN at 8 mm/s
/// and 1.5 mm (the paper's), plus
/// `word_rows` rows of random words (beyond the paper: letters with neighbours at the cell
/// spacing, as in words; the single-letter boards spread their letters over the row), split by
/// whole scans (every fifth trial goes to validation when there are five or more), so no scan
/// feeds both.
#[allow(clippy::too_many_arguments)]
pub fn training_windows(
    trials: u64,
    seed: u64,
    word_rows: usize,
    input: &CharInput,
    task: Task,
    jitter_ms: f64,
    blank_cells: bool,
    world: &World,
    progress: &dyn Progress,
) -> Result<TrainingWindows> {
    let mut boards = vec![BoardKind::Sab, BoardKind::Un];
    if word_rows > 0 {
        let text = random_word_rows(seed ^ 0x5745_5244, word_rows, 22, &EV_WORDS);
        boards.push(BoardKind::Text(text));
    }
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
    };
    let (all, w) = build(&spec, input, progress)?;
    let (val, train): (Vec<usize>, Vec<usize>) =
        (0..all.len()).partition(|&i| trials >= 5 && w.origin[i].trial % 5 == 4);
    Ok(TrainingWindows { all, train, val, scans: w.scans, skipped_scans: w.skipped_scans })
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

#[cfg(test)]
mod tests {
    use super::*;

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
