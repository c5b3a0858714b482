//! The character classifiers on SIMULATED windows: scoring a model of either architecture on a
//! set of windows (`braille eval chars`, Table I) and the ResNet's training protocol
//! (`braille train --arch resnet`).

use crate::Progress;
use crate::error::Result;
use crate::eval::scoring::Confusion;
use crate::eval::tactile::{async_capable, snn_accuracy};
use corpus::windows::{CharSetSpec, ScanId, Task, build, snn_set};
use encoders::braille::Cell;
use learn::resnet::ImageSet;
use learn::snn::{SnnParams, SnnTwin};
use pipeline::input::CharInput;
use pipeline::models::Model;
use rayon::prelude::*;
use serde::Serialize;
use snn::engine::Mode;
use snn::model_file::Arch;
use snn::neuron::Surrogate;
use std::path::Path;

/// A character classifier of either architecture, with how its input is made.
pub struct CharModel {
    pub model: Model,
    pub input: CharInput,
}

/// How a classifier did on a set of windows.
#[derive(Debug, Clone, Serialize)]
pub struct Score {
    pub n: usize,
    pub accuracy: f64,
    pub macro_f1: f64,
    /// Cross-entropy of the network's outputs (the SNN's: of its time-stepped twin, which the
    /// stepped engine reproduces spike for spike).
    pub loss: f64,
    /// `[truth][predicted]`.
    pub confusion: Vec<Vec<u32>>,
    /// SNN only: the event-driven engine's work per window (stepped mode), and its accuracy in
    /// async mode where the network allows it (LIF/IF layers without bias or recurrence).
    pub synops_per_sample: Option<f64>,
    pub spikes_per_sample: Option<f64>,
    pub input_events_per_sample: Option<f64>,
    pub accuracy_async: Option<f64>,
    /// The class read for each window, in the set's order.
    #[serde(skip)]
    pub predictions: Vec<usize>,
    /// What the classifier read on each scan of trial 0 (filled where the windows' scans are
    /// known, [`Score::with_first_trial`]): a small slice of the score that a golden test can
    /// recompute from the model and the seed.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub first_trial: Vec<ScanRead>,
}

/// What a classifier read on one scan: the letters of the windows the labeler found, in order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ScanRead {
    pub board: String,
    pub row: usize,
    pub truth: String,
    pub read: String,
}

impl Score {
    /// An SNN's score on windows (the work per window its run's), with the loss of its twin
    /// and the async engine's accuracy beside it where they exist.
    fn spiking(s: crate::eval::tactile::Scored, loss: f64, accuracy_async: Option<f64>) -> Score {
        Score {
            n: s.n,
            accuracy: s.accuracy,
            macro_f1: crate::eval::scoring::macro_f1(&s.confusion),
            loss,
            confusion: s.confusion,
            synops_per_sample: Some(s.synops_per_sample),
            spikes_per_sample: Some(s.spikes_per_sample),
            input_events_per_sample: Some(s.input_events_per_sample),
            accuracy_async,
            predictions: s.predictions.iter().map(|p| p.0).collect(),
            first_trial: vec![],
        }
    }

    /// A score from the class read for each window (`labels` the true ones) and the loss: no
    /// spiking work.
    fn of_reads(classes: usize, labels: &[usize], predictions: Vec<usize>, loss: f64) -> Score {
        let confusion = Confusion::from_pairs(classes, labels.iter().copied().zip(predictions.iter().copied()));
        Score {
            n: predictions.len(),
            accuracy: confusion.accuracy(),
            macro_f1: confusion.macro_f1(),
            loss,
            confusion: confusion.counts,
            synops_per_sample: None,
            spikes_per_sample: None,
            input_events_per_sample: None,
            accuracy_async: None,
            predictions,
            first_trial: vec![],
        }
    }

    /// The score with each window read as `predictions` instead: confusion, accuracy and macro
    /// F1 recounted, the rest (loss, work, async accuracy) kept.
    fn with_reads(self, labels: &[usize], predictions: Vec<usize>) -> Score {
        let r = Score::of_reads(self.confusion.len(), labels, predictions, self.loss);
        Score { accuracy: r.accuracy, macro_f1: r.macro_f1, confusion: r.confusion, predictions: r.predictions, ..self }
    }

    /// The score with [`Score::first_trial`] filled from the windows' scans (`origin`, one per
    /// window, in the order scored) and the windows' true classes.
    pub fn with_first_trial(mut self, origin: &[ScanId], labels: &[usize]) -> Score {
        let n = self.confusion.len();
        let letter = |c: usize| match pipeline::words::Alphabet::of_classes(n) {
            pipeline::words::Alphabet::Cells => pipeline::words::Alphabet::Cells.symbol(c),
            _ => char::from(b'a' + c.min(25) as u8),
        };
        let mut reads: Vec<ScanRead> = Vec::new();
        for ((scan, &truth), &pred) in origin.iter().zip(labels).zip(&self.predictions) {
            if scan.trial != 0 {
                continue;
            }
            match reads.last_mut() {
                Some(r) if r.board == scan.board && r.row == scan.row => {}
                _ => reads.push(ScanRead {
                    board: scan.board.clone(),
                    row: scan.row,
                    truth: String::new(),
                    read: String::new(),
                }),
            }
            let r = reads.last_mut().expect("pushed above");
            r.truth.push(letter(truth));
            r.read.push(letter(pred));
        }
        self.first_trial = reads;
        self
    }
}

impl CharModel {
    /// A model file of either architecture (its header says which) that reads character windows.
    pub fn load(path: &Path) -> Result<CharModel> {
        let model = pipeline::models::load(path)?;
        let input = model.char_input(path)?;
        Ok(CharModel { model, input })
    }

    pub fn arch(&self) -> Arch {
        self.model.arch()
    }

    /// What its classes are: the 26 letters or the 63 cells.
    pub fn task(&self) -> Task {
        Task::for_classes(self.model.classes().len())
    }

    /// ResNet: multiply-accumulates per window.
    pub fn macs(&self) -> Option<u64> {
        match &self.model {
            Model::Resnet(r) => Some(r.config.macs()),
            Model::Snn(_) => None,
        }
    }

    /// Scores the windows of `raw` (crops as [`build`] makes them for this model).
    pub fn score(&self, raw: &ImageSet) -> Result<Score> {
        match &self.model {
            Model::Resnet(m) => {
                let set = ImageSet {
                    shape: raw.shape,
                    data: raw.data.par_iter().map(|d| m.input.prepare(d)).collect(),
                    labels: raw.labels.clone(),
                };
                // (its accuracy, hits over windows, is the confusion's)
                let model = learn::resnet::from_tensors(&m.config, &m.tensors)?;
                let (loss, _, predictions) = learn::resnet::evaluate(&model, &set, 32);
                Ok(Score::of_reads(self.model.classes().len(), &set.labels, predictions, loss))
            }
            Model::Snn(model) => {
                let set =
                    snn_set(&self.input, raw, &(0..raw.len()).collect::<Vec<_>>(), model.config.dt_us, self.task());
                let stepped = snn_accuracy(&model.network, &model.config, &set, Mode::Stepped)?;
                let accuracy_async = if async_capable(&model.network, model.config.dt_us) {
                    Some(snn_accuracy(&model.network, &model.config, &set, Mode::Async)?.accuracy)
                } else {
                    None
                };
                let twin = SnnTwin::new(
                    model.config.network.clone(),
                    Surrogate::FastSigmoid { slope: 1.0 },
                    model.config.readout,
                )?;
                let params = SnnParams::from_weights(
                    &model.config.network,
                    &model.network.weights(),
                    &burn::tensor::Device::flex(),
                )?;
                let (loss, _, _) = learn::train::evaluate(&twin, &params, &set, 64);
                Ok(Score::spiking(stepped, loss, accuracy_async))
            }
        }
    }
}

/// A classifier scored on fresh SIMULATED scans (`braille eval chars`).
#[derive(Debug, Clone, Serialize)]
pub struct CharEval {
    pub data: &'static str,
    pub arch: Arch,
    pub model: String,
    pub board: String,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    /// Simulated scans: their seed and the sensor builds that made them (`corpus::world`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scan_seed: Option<u64>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sensor_builds: Vec<u64>,
    pub scans: usize,
    pub skipped_scans: usize,
    /// Characters printed on every scan, and the share read right of them (the characters of
    /// scans the labeler miscounted count as errors); `accuracy` is over the windows found.
    pub printed: usize,
    pub accuracy_all: f64,
    #[serde(flatten)]
    pub score: Score,
    /// Cells: what the cell grid changed (the score above is after it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid: Option<GridEffect>,
}

/// Scores the model at `path` on the windows of `spec`.
pub fn eval(path: &Path, spec: &CharSetSpec, progress: &dyn Progress) -> Result<CharEval> {
    let m = CharModel::load(path)?;
    // the windows labelled as the model's classes are (letters or cells)
    let spec = &CharSetSpec { task: m.task(), ..spec.clone() };
    let (raw, w) = build(spec, &m.input, progress)?;
    let (score, grid) = on_the_grid(m.score(&raw)?, &w, &raw.labels, spec.task);
    let score = score.with_first_trial(&w.origin, &raw.labels);
    Ok(CharEval::of(&m, path, spec, &w, score, grid))
}

/// What the cell grid did to a cell classifier's reading of labelled windows.
#[derive(Debug, Clone, Serialize)]
pub struct GridEffect {
    /// Windows whose one-column cell the grid moved into the other column.
    pub moved: usize,
    /// The classifier's reading before (over the windows found, and over every printed cell).
    pub accuracy_classifier_alone: f64,
    pub accuracy_all_classifier_alone: f64,
}

/// For cells: `score` with each one-column cell read put in the column the cell grid gives it
/// from its scan's marks (`pipeline::grid`: the labeler's peaks, the speed estimated from the
/// events), as a reader of print does; the confusion and accuracy recounted. Letters as they are.
pub fn on_the_grid(
    score: Score,
    w: &corpus::windows::Windows,
    labels: &[usize],
    task: Task,
) -> (Score, Option<GridEffect>) {
    if task != Task::Cells || w.marks.len() != score.predictions.len() {
        return (score, None);
    }
    let grid = pipeline::grid::CellGrid::default();
    let before = (score.accuracy, w.accuracy_all(crate::reports::chars::right(&score)));
    let mut placed = Vec::with_capacity(score.predictions.len());
    // one scan's windows are together, in reading order
    for scan in w.origin.chunk_by(|a, b| a == b) {
        let (start, end) = (placed.len(), placed.len() + scan.len());
        let cells: Vec<Cell> = score.predictions[start..end].iter().map(|&k| Cell((k + 1) as u8)).collect();
        placed.extend(grid.place(&cells, &w.marks[start..end]).into_iter().map(|c| usize::from(c.0) - 1));
    }
    let moved = placed.iter().zip(&score.predictions).filter(|(a, b)| a != b).count();
    let score = score.with_reads(labels, placed);
    let effect = GridEffect { moved, accuracy_classifier_alone: before.0, accuracy_all_classifier_alone: before.1 };
    (score, Some(effect))
}

impl CharEval {
    /// `score` of model `m` (file `path`) on the windows `w` of `spec`.
    fn of(
        m: &CharModel,
        path: &Path,
        spec: &CharSetSpec,
        w: &corpus::windows::Windows,
        score: Score,
        grid: Option<GridEffect>,
    ) -> CharEval {
        let right = crate::reports::chars::right(&score);
        CharEval {
            data: "simulated (virtual Evetac)",
            arch: m.arch(),
            model: path.display().to_string(),
            board: spec.boards.iter().map(corpus::boards::board_name).collect::<Vec<_>>().join(","),
            speed_mm_s: spec.speed_mm_s,
            depth_mm: spec.depth_mm,
            scan_seed: Some(spec.seed),
            sensor_builds: spec.world.sensors.clone(),
            scans: w.scans,
            skipped_scans: w.skipped_scans,
            printed: w.printed,
            accuracy_all: w.accuracy_all(right),
            score,
            grid,
        }
    }
}

/// A character SNN on simulated windows in a chip's arithmetic (`braille eval chars --chip`).
#[derive(Debug, Clone, Serialize)]
pub struct CharChipEval {
    #[serde(flatten)]
    pub eval: CharEval,
    pub chip: crate::eval::chip::ChipChoice,
    /// What the mapping changed.
    pub approximations: Vec<String>,
    pub neuron_updates_per_sample: f64,
}

/// Scores the SNN at `path` on the windows of `spec` mapped into `choice`'s chip, every window as
/// the chip computes it (the windows and their encoding are [`eval`]'s); with `trace`, every
/// window as the chip ran it.
pub fn eval_chip(
    path: &Path,
    spec: &CharSetSpec,
    choice: crate::eval::chip::ChipChoice,
    trace: bool,
    progress: &dyn Progress,
) -> Result<(CharChipEval, Option<crate::eval::chip::ChipTrace>)> {
    use crate::eval::chip::{ChipTrace, chip_accuracy, map_model};
    let m = CharModel::load(path)?;
    let Model::Snn(model) = &m.model else {
        return Err(crate::Error::Model {
            path: path.to_path_buf(),
            what: "a chip runs spiking networks: this model is a ResNet".into(),
        });
    };
    let spec = &CharSetSpec { task: m.task(), ..spec.clone() };
    let (raw, w) = build(spec, &m.input, progress)?;
    let set = snn_set(&m.input, &raw, &(0..raw.len()).collect::<Vec<_>>(), model.config.dt_us, m.task());
    let mapped = map_model(model, path, choice)?;
    let (s, updates) = chip_accuracy(&mapped.model, &set, choice.run)?;
    // no loss in the chip's arithmetic: its readout is a spike count, not logits
    let (score, grid) = on_the_grid(Score::spiking(s, f64::NAN, None), &w, &raw.labels, spec.task);
    let score = score.with_first_trial(&w.origin, &raw.labels);
    let eval = CharEval::of(&m, path, spec, &w, score, grid);
    let trace = if trace {
        let data = format!("{} at {} mm/s, {} mm, seed {}", eval.board, spec.speed_mm_s, spec.depth_mm, spec.seed);
        Some(ChipTrace::of(&mapped.model, model, path, data, "windows", choice, &set, progress)?)
    } else {
        None
    };
    Ok((
        CharChipEval { eval, chip: choice, approximations: mapped.approximations, neuron_updates_per_sample: updates },
        trace,
    ))
}

/// Scores the model at `path` on the windows of a recordings folder's scans of `role` (the
/// labeler told each scan's character count and commanded speed by the manifest, as for
/// simulated scans), one score per commanded speed and depth (`braille eval chars
/// --recordings`).
pub fn eval_recordings(
    path: &Path,
    rec: &corpus::recordings::Recordings,
    role: corpus::recordings::Role,
    progress: &dyn Progress,
) -> Result<Vec<CharEval>> {
    let m = CharModel::load(path)?;
    let mut out = Vec::new();
    for (speed_mm_s, depth_mm) in rec.conditions(role) {
        let scans: Vec<&corpus::recordings::Recording> =
            rec.role(role).filter(|r| r.speed_mm_s == speed_mm_s && r.depth_mm == depth_mm).collect();
        let mut w = corpus::windows::recorded_windows(rec, &scans, &[&m.input], m.task(), 0.0, false, progress)?;
        let raw = w.sets.remove(0);
        let (score, grid) = on_the_grid(m.score(&raw)?, &w, &raw.labels, m.task());
        let right = crate::reports::chars::right(&score);
        out.push(CharEval {
            data: "recorded scans",
            arch: m.arch(),
            model: path.display().to_string(),
            board: format!("{} ({} scans)", rec.dir.display(), role.name()),
            speed_mm_s,
            depth_mm,
            scan_seed: None,
            sensor_builds: Vec::new(),
            scans: w.scans,
            skipped_scans: w.skipped_scans,
            printed: w.printed,
            accuracy_all: w.accuracy_all(right),
            score,
            grid,
        });
    }
    Ok(out)
}

/// What `braille eval chars --chip` prints: the score, then what the chip's mapping changed.
impl std::fmt::Display for CharChipEval {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.eval)?;
        let c = &self.chip;
        writeln!(
            f,
            "in {}'s arithmetic ({:?} quantisation, {:?} run): {:.0} neuron updates per window; what the mapping changed:",
            c.chip, c.quantisation, c.run, self.neuron_updates_per_sample
        )?;
        self.approximations.iter().try_for_each(|a| writeln!(f, "  {a}"))
    }
}

/// The line `braille eval chars` prints.
impl std::fmt::Display for CharEval {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.score;
        writeln!(
            f,
            "{} {} at {} mm/s, {} mm: {} windows from {} scans ({} skipped), {} printed characters: {} accuracy {:.2}% of the windows, {:.2}% of all printed, macro F1 {:.3}, loss {:.3}{}{}",
            if self.data.starts_with("simulated") { "SIMULATED" } else { "RECORDED" },
            self.board,
            self.speed_mm_s,
            self.depth_mm,
            s.n,
            self.scans,
            self.skipped_scans,
            self.printed,
            self.arch,
            100.0 * s.accuracy,
            100.0 * self.accuracy_all,
            s.macro_f1,
            s.loss,
            s.accuracy_async.map_or(String::new(), |a| format!(" (async engine {:.2}%)", 100.0 * a)),
            self.grid.as_ref().map_or(String::new(), |g| format!(
                "; the cell grid moved {} cells (the classifier alone: {:.2}% of all printed)",
                g.moved,
                100.0 * g.accuracy_all_classifier_alone
            ))
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use corpus::windows::Windows;
    use pipeline::grid::GridMark;

    #[test]
    fn cells_read_in_the_wrong_column_are_placed_on_their_scans_grid() {
        // two scans of ⠉ ⠈ (dots 1-4, then dot 4 alone one cell on) at 8 mm/s: marks at each
        // cell's last column, 750 ms apart; the classifier read ⠁ (dot 1) for ⠈ in both, and ⠉
        // right. The second scan's speed is unknown: its ⠁ stands.
        let (c14, c4, c1) = (0b001_001 - 1, 0b001_000 - 1, 0b000_001 - 1);
        let mark = |t_ms: i64, two: bool, known: bool| GridMark {
            t_us: t_ms * 1000,
            two_columns: two,
            speed_mm_s: known.then_some(8.0),
        };
        let scan = |trial| ScanId { board: "RCB".into(), row: 0, trial };
        let w = Windows {
            sets: Vec::new(),
            origin: vec![scan(0), scan(0), scan(1), scan(1)],
            marks: vec![mark(0, true, true), mark(750, false, true), mark(0, true, false), mark(750, false, false)],
            scans: 2,
            skipped_scans: 0,
            printed: 4,
        };
        let labels = [c14, c4, c14, c4];
        let score = Score::of_reads(63, &labels, vec![c14, c1, c14, c1], 0.0);
        let (letters, none) = on_the_grid(score.clone(), &w, &labels, Task::Chars);
        assert!(none.is_none());
        assert_eq!(letters.predictions, score.predictions);
        let (placed, effect) = on_the_grid(score, &w, &labels, Task::Cells);
        assert_eq!(placed.predictions, [c14, c4, c14, c1]);
        assert_eq!(placed.accuracy, 0.75);
        assert_eq!(placed.confusion[c4][c4], 1);
        let effect = effect.unwrap();
        assert_eq!(
            (effect.moved, effect.accuracy_classifier_alone, effect.accuracy_all_classifier_alone),
            (1, 0.5, 0.5)
        );
    }
}
