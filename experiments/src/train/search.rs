//! Training on a tactile dataset nobody has tuned for: a recipe derived from the data
//! ([`DataProfile`], [`derived_recipe`]) and a validation-driven search around it ([`SearchSpace`],
//! [`run_trials`], [`read_logs`], [`winner`]) that can be spread over machines (`--shard I/N`, one log per
//! shard, and `--collect` over the logs).
//!
//! Nothing here knows a dataset: every default is a rule on the training split's durations,
//! event counts and signal steps, documented in docs/training.md. The test split is never read
//! to choose; the search validates on the folder's own validation split, or on a stratified
//! hold-out of the training split.

use crate::error::{Error, Result};
use crate::train::fit::{EvalTest, TactileData, TrainedSnn, train_on};
use crate::train::recipe::{SnnRecipe, TrainerChoice};
use encoders::dataset::{Dataset, DatasetKind, SampleData, Split};
use learn::data::TactileEncoding;
use learn::train::{EpochReport, Observer};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

/// What the training split looks like, measured before any choice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataProfile {
    /// The folder's name.
    pub data: String,
    /// `events` or `analog`.
    pub kind: String,
    pub channels: usize,
    pub classes: usize,
    pub train_samples: usize,
    /// The 95th percentile of the training samples' durations (last event, or frames times
    /// the sampling period).
    pub duration_us: i64,
    /// Event data: mean events per training sample.
    pub events_per_sample: Option<f64>,
    /// Analog data: the median of the non-zero absolute changes between consecutive frames of a
    /// channel (the signal's step), which becomes the sigma-delta threshold.
    pub signal_step: Option<f32>,
    pub period_us: i64,
}

impl DataProfile {
    /// Measures the training split of `data`.
    pub fn of(data: &Dataset) -> Result<DataProfile> {
        let mut durations = Vec::new();
        let (mut events, mut steps) = (0usize, Vec::new());
        for s in data.split(Split::Train) {
            match &s.data {
                SampleData::Events(ev) => {
                    events += ev.len();
                    durations.push(ev.last().map_or(0, |e| e.t_us + 1));
                }
                SampleData::Analog { frames } => {
                    let c = data.channels.max(1);
                    durations.push((frames.len() / c) as i64 * data.period_us);
                    for ch in 0..c {
                        let mut last: Option<f32> = None;
                        for v in frames.iter().skip(ch).step_by(c) {
                            if let Some(l) = last {
                                let d = (v - l).abs();
                                if d > 0.0 {
                                    steps.push(d);
                                }
                            }
                            last = Some(*v);
                        }
                    }
                }
            }
        }
        if durations.is_empty() {
            return Err(Error::Data { path: data.dir.clone(), what: "no training samples".into() });
        }
        durations.sort_unstable();
        let p95 = durations[((durations.len() - 1) as f64 * 0.95).round() as usize];
        let n = durations.len();
        let signal_step = (!steps.is_empty()).then(|| {
            steps.sort_unstable_by(f32::total_cmp);
            steps[steps.len() / 2]
        });
        Ok(DataProfile {
            data: data.dir.file_name().map_or_else(|| data.dir.display().to_string(), |f| f.to_string_lossy().into()),
            kind: match data.kind {
                DatasetKind::Events => "events".into(),
                DatasetKind::Analog => "analog".into(),
            },
            channels: data.channels,
            classes: data.classes.len(),
            train_samples: n,
            duration_us: p95.max(1),
            events_per_sample: (data.kind == DatasetKind::Events).then(|| events as f64 / n as f64),
            signal_step,
            period_us: data.period_us,
        })
    }
}

impl std::fmt::Display for DataProfile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} data, {} channels, {} classes, {} training samples, duration (95th percentile) {:.0} ms",
            self.data,
            self.kind,
            self.channels,
            self.classes,
            self.train_samples,
            self.duration_us as f64 / 1000.0
        )?;
        if let Some(e) = self.events_per_sample {
            write!(f, ", {e:.1} events per sample")?;
        }
        if let Some(v) = self.signal_step {
            write!(f, ", the signal's median step {v}")?;
        }
        Ok(())
    }
}

/// The largest of 1, 2 and 5 times a power of ten that is at most `x` (at least 1).
pub fn nice_floor(x: f64) -> f64 {
    if x < 1.0 {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0].into_iter().map(|m| m * p).find(|&v| v <= x).unwrap_or(p)
}

/// The recipe the data implies (docs/training.md, "Defaults from the data"):
/// - step: the 1-2-5 value at most 1/100 of the samples' duration (95th percentile);
/// - hidden membrane time constant 1/12 of the duration, synaptic half of that, readout 1/3;
/// - analog data: the sigma-delta threshold at the signal's median step;
/// - the hidden layer recurrent with its recurrent weights starting at zero (the network starts
///   feed-forward and grows its recurrence), neuron dropout 0.2, a bias, weights at half
///   PyTorch's initial scale, Adam 1e-3 with the gradient norm clipped to 1, 100 epochs, the
///   weights averaged over the last 30 (competing with the best checkpoint on a 10% hold-out);
///   these fixed choices come from the th10 recipe; the search's neighbour trials measure each of
///   them again on validation (docs/training.md);
/// - a learning-rate warm-up over the first [`WARMUP_STEPS`] steps (chosen on validation).
pub fn derived_recipe(p: &DataProfile) -> SnnRecipe {
    let d = p.duration_us as f64;
    let dt_us = (nice_floor(d / 100.0) as i64).max(1);
    let tau_mem_us = (d / 12.0).max(dt_us as f64);
    let base = SnnRecipe::default();
    SnnRecipe {
        period_us: if p.period_us > 0 { p.period_us } else { base.period_us },
        sigma_delta: p.signal_step.unwrap_or(base.sigma_delta),
        dt_us,
        tau_mem_us,
        tau_syn_us: tau_mem_us / 2.0,
        tau_out_us: (d / 3.0).max(dt_us as f64),
        recurrent: true,
        recurrent_init_gain: Some(0.0),
        dropout: 0.2,
        bias: true,
        init_gain: 0.5,
        lr: 1e-3,
        warmup_steps: WARMUP_STEPS,
        clip_norm: 1.0,
        epochs: 100,
        average_epochs: 30,
        ..base
    }
}

/// The derived recipe's learning-rate warm-up, in optimiser steps. Without it some seeds' recurrent
/// layer runs away in the first Adam steps and never trains (spikes per sample from 2 400 to
/// 7 000, accuracy at chance). Chosen on validation (2026-11-25; the mean validation accuracy over
/// the last 5 of 60 epochs, seeds 1-3, 0 against 100 steps): raw1350 81.9% against 91.2%, th10
/// 75.1% against 75.4%, the simulated taxel set 97.8% against 97.8% (docs/training.md).
pub const WARMUP_STEPS: usize = 100;

/// One point of the search space, relative to the derived recipe.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SearchPoint {
    /// Hidden membrane and synaptic time constants times this.
    pub tau_scale: f64,
    /// The readout's time constant times this.
    pub readout_tau_scale: f64,
    /// Recurrent hidden layer (its recurrent weights starting at zero), or feed-forward.
    pub recurrent: bool,
    pub hidden: usize,
    pub dropout: f64,
    pub lr: f64,
    pub init_gain: f32,
    /// The step `dt_us` times this (the input re-encoded at that step). Absent from logs written
    /// before 2026-12-01, which read as 1; not written when 1, so those logs stay as they were.
    #[serde(default = "unit", skip_serializing_if = "is_unit")]
    pub step_scale: f64,
}

fn unit() -> f64 {
    1.0
}

fn is_unit(v: &f64) -> bool {
    *v == 1.0
}

fn units() -> Vec<f64> {
    vec![1.0]
}

fn are_units(v: &[f64]) -> bool {
    v == [1.0]
}

impl SearchPoint {
    /// The derived recipe moved to this point, trained for the search's epochs with early
    /// stopping on the hold-out. The base's depth is kept (`--hidden 256,256` searches two
    /// hidden layers), each at the point's width.
    pub fn recipe(&self, base: &SnnRecipe, space: &SearchSpace) -> SnnRecipe {
        SnnRecipe {
            tau_mem_us: base.tau_mem_us * self.tau_scale,
            tau_syn_us: base.tau_syn_us * self.tau_scale,
            tau_out_us: base.tau_out_us * self.readout_tau_scale,
            dt_us: scaled_step(base.dt_us, self.step_scale),
            recurrent: self.recurrent,
            recurrent_init_gain: self.recurrent.then_some(0.0),
            hidden: vec![self.hidden; base.hidden.len().max(1)],
            dropout: self.dropout,
            lr: self.lr,
            init_gain: self.init_gain,
            epochs: space.epochs,
            patience: space.patience,
            average_epochs: 0,
            val_fraction: space.val_fraction,
            val_seed: Some(space.val_seed),
            seed: space.trial_seed,
            ..base.clone()
        }
    }

    /// The point of the derived recipe itself.
    pub fn derived(base: &SnnRecipe) -> SearchPoint {
        SearchPoint {
            tau_scale: 1.0,
            readout_tau_scale: 1.0,
            recurrent: base.recurrent,
            hidden: base.hidden.first().copied().unwrap_or(256),
            dropout: base.dropout,
            lr: base.lr,
            init_gain: base.init_gain,
            step_scale: 1.0,
        }
    }
}

/// `dt_us` times `scale`, in whole microseconds (at least one).
fn scaled_step(dt_us: i64, scale: f64) -> i64 {
    if scale == 1.0 { dt_us } else { ((dt_us as f64 * scale).round() as i64).max(1) }
}

/// The documented search space and how each trial is run (docs/training.md, "The search").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchSpace {
    pub tau_scale: Vec<f64>,
    pub readout_tau_scale: Vec<f64>,
    pub recurrent: Vec<bool>,
    pub hidden: Vec<usize>,
    pub dropout: Vec<f64>,
    pub lr: Vec<f64>,
    pub init_gain: Vec<f32>,
    /// The SNN's step times each of these (`--search-step-scale`), as the conventional networks
    /// search their bins (`braille baselines --search`); `[1]` (the default): the derived step
    /// only, and the same points as before this dimension existed.
    #[serde(default = "units", skip_serializing_if = "are_units")]
    pub step_scale: Vec<f64>,
    /// Epochs at most per trial.
    pub epochs: usize,
    /// A trial stops after this many epochs without a better validation accuracy.
    pub patience: usize,
    /// A trial's score: its mean validation accuracy over its last this many epochs.
    pub score_epochs: usize,
    /// Share of the training split held out (when the folder has no validation split).
    pub val_fraction: f64,
    pub val_seed: u64,
    /// Every trial's first initialisation and shuffling seed (so trials differ by their point
    /// only).
    pub trial_seed: u64,
    /// Seeds per trial (`trial_seed`, `trial_seed + 1`, ...): the score is their mean, so that a
    /// recipe that only some seeds train well loses. 3 by default since 2026-11-25 (single-seed
    /// winners fell apart over three seeds on raw1350's validation hold-out; logs written
    /// before `trial_seeds` existed read as 1).
    #[serde(default = "one")]
    pub trial_seeds: u64,
    /// Trials at most; trial 0 is the derived recipe, the rest are drawn from the space.
    pub trials: usize,
    /// The draw's seed.
    pub seed: u64,
    /// Successive halving instead of one rung of trials ([`Halving`]; `None`: every trial at the
    /// space's epochs, as before 2026-12-01).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub halving: Option<Halving>,
}

/// Successive halving (Jamieson and Talwalkar, AISTATS 2016; the inner loop of Hyperband, Li et
/// al., JMLR 18, 2018): more points, each first trained briefly, the best of each rung promoted
/// to the next, longer one. Rung `r` of `rungs` trains its points for `epochs / eta^(rungs-1-r)`
/// epochs (the last rung the space's epochs), with the space's seeds per trial, and promotes the
/// best `1/eta` of them by score (ties to the earlier point). The first rung has `trials *
/// eta^(rungs-1) / rungs` points, so each rung costs about `trials / rungs` full trials and the
/// whole search about what `trials` full trials cost: the same budget, more recipes tried (48
/// against 16 at the defaults). The last rung's trials are the search's trials (its logs, its
/// winner); the earlier rungs are logged in `rung-R.jsonl` beside them. A short rung's score is
/// the mean over its last `score_epochs` scaled to its length (at least one epoch).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Halving {
    pub eta: usize,
    pub rungs: usize,
}

impl Halving {
    /// Keep one in three, three rungs.
    pub const DEFAULT: Halving = Halving { eta: 3, rungs: 3 };

    fn factor(&self, rungs_after: usize) -> usize {
        self.eta.max(2).saturating_pow(rungs_after as u32)
    }

    /// Points in the first rung, for the budget of `trials` full trials.
    pub fn first_rung_points(&self, trials: usize) -> usize {
        (trials * self.factor(self.rungs.max(1) - 1)).div_ceil(self.rungs.max(1))
    }

    /// Points in rung `rung` when the first has `first`.
    pub fn rung_points(&self, rung: usize, first: usize) -> usize {
        (first / self.factor(rung)).max(1)
    }

    /// The space a rung's trials run with: its epochs and its score's epochs.
    pub fn rung_space(&self, rung: usize, space: &SearchSpace) -> SearchSpace {
        let f = self.factor(self.rungs.max(1) - 1 - rung) as f64;
        let epochs = ((space.epochs as f64 / f).round() as usize).max(1);
        let score_epochs = ((space.score_epochs as f64 * epochs as f64 / space.epochs as f64).round() as usize).max(1);
        SearchSpace { epochs, score_epochs, ..space.clone() }
    }

    fn check(&self) -> Result<()> {
        if self.eta < 2 || self.rungs < 2 {
            return Err(Error::Setting {
                name: "successive halving",
                value: format!("eta {}, {} rungs", self.eta, self.rungs),
                expected: "eta 2 or more and 2 rungs or more",
            });
        }
        Ok(())
    }
}

impl Default for SearchSpace {
    fn default() -> Self {
        SearchSpace {
            tau_scale: vec![0.5, 1.0, 2.0, 4.0],
            readout_tau_scale: vec![0.5, 1.0, 2.0],
            recurrent: vec![true, false],
            hidden: vec![128, 256, 512],
            dropout: vec![0.0, 0.1, 0.2],
            lr: vec![5e-4, 1e-3, 2e-3],
            init_gain: vec![0.5, 1.0],
            step_scale: units(),
            epochs: 60,
            patience: 15,
            score_epochs: 5,
            val_fraction: 0.2,
            val_seed: 1,
            trial_seed: 1,
            trial_seeds: 3,
            trials: 16,
            seed: 1,
            halving: None,
        }
    }
}

impl SearchSpace {
    /// The trials' points, in order: the derived recipe's point; then its neighbours, each
    /// dimension's other values one at a time (time constants, recurrence, initial gain, learning
    /// rate, readout, hidden size, dropout, step); then distinct points drawn with the space's
    /// seed. Every shard computes the same list. The step is drawn only when it has more than one
    /// value, so a space with the derived step alone draws what it drew before the step was a
    /// dimension.
    pub fn points(&self, base: &SnnRecipe) -> Vec<SearchPoint> {
        let d = SearchPoint::derived(base);
        let mut points = vec![d];
        let add = |points: &mut Vec<SearchPoint>, p: SearchPoint| {
            if !points.contains(&p) {
                points.push(p);
            }
        };
        for &v in &self.tau_scale {
            add(&mut points, SearchPoint { tau_scale: v, ..d });
        }
        for &v in &self.recurrent {
            add(&mut points, SearchPoint { recurrent: v, ..d });
        }
        for &v in &self.init_gain {
            add(&mut points, SearchPoint { init_gain: v, ..d });
        }
        for &v in &self.lr {
            add(&mut points, SearchPoint { lr: v, ..d });
        }
        for &v in &self.readout_tau_scale {
            add(&mut points, SearchPoint { readout_tau_scale: v, ..d });
        }
        for &v in &self.hidden {
            add(&mut points, SearchPoint { hidden: v, ..d });
        }
        for &v in &self.dropout {
            add(&mut points, SearchPoint { dropout: v, ..d });
        }
        for &v in &self.step_scale {
            add(&mut points, SearchPoint { step_scale: v, ..d });
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(self.seed);
        let size = self.tau_scale.len()
            * self.readout_tau_scale.len()
            * self.recurrent.len()
            * self.hidden.len()
            * self.dropout.len()
            * self.lr.len()
            * self.init_gain.len()
            * self.step_scale.len();
        let want = self.trials.min(size);
        let mut draws = 0;
        while points.len() < want && draws < 100 * want {
            draws += 1;
            fn pick<T: Copy>(rng: &mut impl Rng, v: &[T]) -> T {
                v[rng.random_range(0..v.len())]
            }
            let p = SearchPoint {
                tau_scale: pick(&mut rng, &self.tau_scale),
                readout_tau_scale: pick(&mut rng, &self.readout_tau_scale),
                recurrent: pick(&mut rng, &self.recurrent),
                hidden: pick(&mut rng, &self.hidden),
                dropout: pick(&mut rng, &self.dropout),
                lr: pick(&mut rng, &self.lr),
                init_gain: pick(&mut rng, &self.init_gain),
                step_scale: match self.step_scale[..] {
                    [one] => one,
                    _ => pick(&mut rng, &self.step_scale),
                },
            };
            add(&mut points, p);
        }
        points.truncate(self.trials);
        points
    }

    fn check(&self) -> Result<()> {
        let empty = [
            self.tau_scale.is_empty(),
            self.readout_tau_scale.is_empty(),
            self.recurrent.is_empty(),
            self.hidden.is_empty(),
            self.dropout.is_empty(),
            self.lr.is_empty(),
            self.init_gain.is_empty(),
            self.step_scale.is_empty(),
        ];
        if empty.iter().any(|&e| e) || self.epochs == 0 || self.trials == 0 || self.score_epochs == 0 {
            return Err(Error::Setting {
                name: "search space",
                value: format!("{} trials, {} epochs", self.trials, self.epochs),
                expected: "a value in every dimension, epochs and trials",
            });
        }
        if let Some(v) = self.step_scale.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(Error::Setting {
                name: "search step scale",
                value: v.to_string(),
                expected: "positive multiples of the derived step",
            });
        }
        self.halving.as_ref().map_or(Ok(()), Halving::check)
    }
}

fn one() -> u64 {
    1
}

/// One trial as its shard logged it (a JSON line).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Trial {
    pub trial: usize,
    pub point: SearchPoint,
    pub recipe: SnnRecipe,
    /// Mean validation accuracy over the last `score_epochs` epochs run and kept (the mean over
    /// the trial's seeds).
    pub score: f64,
    /// Each seed's score, when a trial trains several ([`SearchSpace::trial_seeds`]).
    #[serde(default)]
    pub seed_scores: Vec<f64>,
    pub best_val_accuracy: f64,
    pub best_epoch: usize,
    /// The most epochs any of its seeds ran.
    pub epochs_run: usize,
    /// The lowest final training accuracy of its seeds.
    pub final_train_accuracy: f64,
    /// Epochs the loss-spike guard undid, over all its seeds (0 without the guard, and in logs
    /// from before 2026-12-01).
    #[serde(default, skip_serializing_if = "super::recipe::is_zero_count")]
    pub undone_epochs: usize,
    /// The first seed's validation accuracy per epoch kept (the loss-spike guard's undone epochs
    /// have none).
    pub val_accuracy: Vec<f64>,
    pub seconds: f64,
    /// `I/N`: the shard that ran it.
    pub shard: String,
    pub profile: DataProfile,
}

/// Which share of the trials this process runs: every `count`-th trial from `index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N` (0 <= I < N).
    pub fn parse(s: &str) -> Result<Shard> {
        let bad = || Error::Setting { name: "shard", value: s.to_string(), expected: "I/N with 0 <= I < N" };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    fn runs(&self, trial: usize) -> bool {
        trial % self.count == self.index
    }

    fn log(&self, dir: &Path) -> PathBuf {
        dir.join(format!("trials-{}-of-{}.jsonl", self.index, self.count))
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The trials logged in `dir` (every `trials-*.jsonl`), by trial number. A line that does not
/// parse is an error naming the file and the line.
pub fn read_logs(dir: &Path) -> Result<Vec<Trial>> {
    read_logs_named(dir, |n| n.starts_with("trials-") && n.ends_with(".jsonl"))
}

/// The trials of a successive-halving search's rung `rung` (not the last), as [`read_logs`].
pub fn read_rung_log(dir: &Path, rung: usize) -> Result<Vec<Trial>> {
    let name = rung_log_name(rung);
    if !dir.join(&name).exists() {
        return Ok(Vec::new());
    }
    read_logs_named(dir, |n| n == name)
}

fn rung_log_name(rung: usize) -> String {
    format!("rung-{rung}.jsonl")
}

fn read_logs_named(dir: &Path, wanted: impl Fn(&str) -> bool) -> Result<Vec<Trial>> {
    let io = |source| Error::Io { path: dir.to_path_buf(), source };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(&wanted))
        .collect();
    files.sort();
    let mut trials: Vec<Trial> = Vec::new();
    for f in files {
        let file = std::fs::File::open(&f).map_err(|source| Error::Io { path: f.clone(), source })?;
        for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
            let line = line.map_err(|source| Error::Io { path: f.clone(), source })?;
            if line.trim().is_empty() {
                continue;
            }
            let t: Trial = serde_json::from_str(&line).map_err(|e| Error::TrialLine {
                path: f.clone(),
                line: i + 1,
                what: format!("not a trial: {e}"),
            })?;
            if let Some(first) = trials.first()
                && first.profile != t.profile
            {
                return Err(Error::TrialLine {
                    path: f.clone(),
                    line: i + 1,
                    what: format!("a trial on another dataset ({}) than {}", t.profile.data, first.profile.data),
                });
            }
            if !trials.iter().any(|o| o.trial == t.trial) {
                trials.push(t);
            }
        }
    }
    trials.sort_by_key(|t| t.trial);
    Ok(trials)
}

/// Hears about the search as it goes.
pub trait SearchObserver {
    /// A trial begins; its epochs go to the returned observer.
    fn trial_begin(&mut self, _trial: usize, _of: usize, _recipe: &SnnRecipe) {}
    /// A successive-halving search's rung `rung` (of `rungs`) begins: `points` trials of `epochs`.
    fn rung_begin(&mut self, _rung: usize, _rungs: usize, _points: usize, _epochs: usize) {}
    fn epoch(&mut self, _report: &EpochReport) {}
    fn trial_end(&mut self, _trial: &Trial) {}
    /// The winner is chosen; its final models (`seeds` of them) train next with `recipe`.
    fn chosen(&mut self, _winner: &Trial, _recipe: &SnnRecipe, _seeds: u64) {}
    /// A final model is written.
    fn final_model(&mut self, _model: &FinalModel) {}
}

impl SearchObserver for () {}

struct EpochsTo<'a>(&'a mut dyn SearchObserver);
impl Observer for EpochsTo<'_> {
    fn epoch_end(&mut self, report: &EpochReport) {
        self.0.epoch(report);
    }
}

/// A search's time budget, counted from the start of this process's trials. A trial starts only
/// if it and the work kept for after the trials (`reserve_trials`, in trials) are expected to end
/// within `total`, every trial expected to take the mean time of the trials logged so far (the
/// first trial always starts: without it there is no winner).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budget {
    pub total: std::time::Duration,
    /// The time kept for after the trials, in trials.
    pub reserve_trials: f64,
}

impl Budget {
    /// For a search that ends in this process: the combination trial (one trial), then `seeds`
    /// final models. A final model trains one seed, a trial `trial_seeds`, on the whole training
    /// split, `1 / (1 - val_fraction)` times a trial's samples, for the winner's epochs (at most a
    /// trial's).
    pub fn finishing(total: std::time::Duration, space: &SearchSpace, seeds: u64) -> Budget {
        let final_models = seeds.max(1) as f64 / space.trial_seeds.max(1) as f64 / (1.0 - space.val_fraction).max(0.1);
        Budget { total, reserve_trials: 1.0 + final_models }
    }

    /// For one shard of a job array: its trials only (`--collect` runs the rest).
    pub fn shard(total: std::time::Duration) -> Budget {
        Budget { total, reserve_trials: 0.0 }
    }

    /// Whether a trial may start `elapsed` into the budget, trials having taken `mean` each.
    pub fn allows(&self, elapsed: std::time::Duration, mean: Option<std::time::Duration>) -> bool {
        match mean {
            None => true,
            Some(m) => elapsed + m.mul_f64(1.0 + self.reserve_trials) <= self.total,
        }
    }
}

/// Runs this shard's trials on `data` (encoded with `base`), logging each to `dir` as it ends.
/// Trials already in the logs are not run again; a trial starts only if the `budget` allows it
/// ([`Budget::allows`]).
#[allow(clippy::too_many_arguments)]
pub fn run_trials(
    data: &SearchData,
    profile: &DataProfile,
    base: &SnnRecipe,
    space: &SearchSpace,
    shard: Shard,
    dir: &Path,
    budget: Option<Budget>,
    observer: &mut dyn SearchObserver,
) -> Result<Vec<Trial>> {
    space.check()?;
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    let done = read_logs(dir)?;
    if let Some(t) = done.first()
        && t.profile != *profile
    {
        return Err(Error::SearchLog {
            dir: dir.to_path_buf(),
            what: format!("holds the trials of another dataset ({}); use another search folder", t.profile.data),
        });
    }
    let points = space.points(base);
    let mine: Vec<(usize, SearchPoint)> = points.iter().copied().enumerate().filter(|&(k, _)| shard.runs(k)).collect();
    let log = shard.log(dir);
    run_listed(data, profile, base, space, &mine, points.len(), shard, &log, &done, budget, observer)
}

/// Runs the numbered points `listed` at `space`'s epochs, appending each trial to `log`; a point
/// already in `done` (the same number, recipe and seeds) is not run again; a trial starts only if
/// the `budget` allows it.
#[allow(clippy::too_many_arguments)]
fn run_listed(
    data: &SearchData,
    profile: &DataProfile,
    base: &SnnRecipe,
    space: &SearchSpace,
    listed: &[(usize, SearchPoint)],
    of: usize,
    shard: Shard,
    log: &Path,
    done: &[Trial],
    budget: Option<Budget>,
    observer: &mut dyn SearchObserver,
) -> Result<Vec<Trial>> {
    let started = std::time::Instant::now();
    let mut ran = Vec::new();
    for &(k, p) in listed {
        let recipe = p.recipe(base, space);
        if let Some(t) = done.iter().find(|t| {
            t.trial == k && t.recipe == recipe && t.seed_scores.len().max(1) as u64 == space.trial_seeds.max(1)
        }) {
            ran.push(t.clone());
            continue;
        }
        // every trial this search has timed: the logged ones and this process's
        let timed: Vec<f64> = done
            .iter()
            .filter(|t| !ran.iter().any(|r: &Trial| r.trial == t.trial))
            .chain(&ran)
            .map(|t| t.seconds)
            .collect();
        let mean = (!timed.is_empty())
            .then(|| std::time::Duration::from_secs_f64(timed.iter().sum::<f64>() / timed.len() as f64));
        if budget.is_some_and(|b| !b.allows(started.elapsed(), mean)) {
            break;
        }
        ran.push(run_point(data, profile, (k, of), p, base, space, shard, log, observer)?);
    }
    Ok(ran)
}

/// Runs a successive-halving search's trials ([`Halving`]) on `data`, resuming from its logs:
/// every rung before the last (logged in `dir/rung-R.jsonl`), each promoting its best points,
/// then the last rung, whose trials are the search's (`dir/trials-0-of-1.jsonl`), returned.
#[allow(clippy::too_many_arguments)]
pub fn run_halving(
    data: &SearchData,
    profile: &DataProfile,
    base: &SnnRecipe,
    space: &SearchSpace,
    halving: Halving,
    dir: &Path,
    observer: &mut dyn SearchObserver,
) -> Result<Vec<Trial>> {
    space.check()?;
    halving.check()?;
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    let first = halving.first_rung_points(space.trials);
    let points = SearchSpace { trials: first, ..space.clone() }.points(base);
    let mut alive: Vec<(usize, SearchPoint)> = points.iter().copied().enumerate().collect();
    for rung in 0..halving.rungs {
        let rung_space = halving.rung_space(rung, space);
        let last = rung + 1 == halving.rungs;
        let (log, done) = if last {
            (Shard::ALL.log(dir), read_logs(dir)?)
        } else {
            (dir.join(rung_log_name(rung)), read_rung_log(dir, rung)?)
        };
        if let Some(t) = done.iter().find(|t| t.profile != *profile) {
            return Err(Error::SearchLog {
                dir: dir.to_path_buf(),
                what: format!("holds the trials of another dataset ({}); use another search folder", t.profile.data),
            });
        }
        observer.rung_begin(rung, halving.rungs, alive.len(), rung_space.epochs);
        let ran = run_listed(
            data,
            profile,
            base,
            &rung_space,
            &alive,
            points.len(),
            Shard::ALL,
            &log,
            &done,
            None,
            observer,
        )?;
        if last {
            return Ok(ran);
        }
        let promoted = promoted(&ran, halving.rung_points(rung + 1, first));
        alive.retain(|(k, _)| promoted.contains(k));
    }
    unreachable!("the last rung returns")
}

/// The numbers of the `keep` best trials by score (ties to the earlier; a NaN score last).
fn promoted(trials: &[Trial], keep: usize) -> Vec<usize> {
    let key = |t: &Trial| if t.score.is_nan() { f64::NEG_INFINITY } else { t.score };
    let mut ranked: Vec<&Trial> = trials.iter().collect();
    ranked.sort_by(|a, b| key(b).total_cmp(&key(a)).then(a.trial.cmp(&b.trial)));
    ranked.iter().take(keep).map(|t| t.trial).collect()
}

/// The data a search's trials train on: the dataset encoded by the recipe the search is centred
/// on, and encoded again for a trial whose step differs ([`SearchSpace::step_scale`]). The
/// hold-out is drawn from the samples' labels and order, so it is the same at every step.
pub struct SearchData<'a> {
    pub dataset: &'a Dataset,
    /// Encoded by the search's base recipe.
    pub base: TactileData,
}

impl SearchData<'_> {
    /// Whether data encoded by `a` serves `b` (the points differ in the step only; the
    /// sigma-delta threshold is compared too, as a recipe given by hand may change it).
    fn serves(a: &TactileEncoding, b: &SnnRecipe) -> bool {
        a.dt_us == b.dt_us && a.sigma_delta.as_ref().is_none_or(|sd| sd.threshold == b.sigma_delta)
    }

    /// The data encoded as `recipe` asks: the base's, or a new encoding at its step.
    pub fn for_recipe(&self, recipe: &SnnRecipe) -> Result<std::borrow::Cow<'_, TactileData>> {
        Ok(if Self::serves(&self.base.encoding, recipe) {
            std::borrow::Cow::Borrowed(&self.base)
        } else {
            std::borrow::Cow::Owned(TactileData::encode(self.dataset, recipe)?)
        })
    }
}

/// Trains one trial and appends it to its shard's log.
#[allow(clippy::too_many_arguments)]
fn run_point(
    data: &SearchData,
    profile: &DataProfile,
    (k, of): (usize, usize),
    p: SearchPoint,
    base: &SnnRecipe,
    space: &SearchSpace,
    shard: Shard,
    log: &Path,
    observer: &mut dyn SearchObserver,
) -> Result<Trial> {
    let recipe = p.recipe(base, space);
    let log = log.to_path_buf();
    observer.trial_begin(k, of, &recipe);
    let data = data.for_recipe(&recipe)?;
    let runs = (0..space.trial_seeds.max(1))
        .map(|i| {
            let r = SnnRecipe { seed: recipe.seed + i, ..recipe.clone() };
            train_on(&r, &data, EvalTest::No, None, None, &mut EpochsTo(observer))
        })
        .collect::<Result<Vec<_>>>()?;
    let trial = trial_of(k, p, recipe, &runs, space, shard, profile);
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log)
        .map_err(|source| Error::Io { path: log.clone(), source })?;
    let line = serde_json::to_string(&trial).map_err(|source| Error::Json { path: log.clone(), source })?;
    writeln!(f, "{line}").map_err(|source| Error::Io { path: log.clone(), source })?;
    observer.trial_end(&trial);
    Ok(trial)
}

fn trial_of(
    k: usize,
    point: SearchPoint,
    recipe: SnnRecipe,
    runs: &[TrainedSnn],
    space: &SearchSpace,
    shard: Shard,
    profile: &DataProfile,
) -> Trial {
    let seed_scores: Vec<f64> = runs.iter().map(|t| seed_score(&t.history, space.score_epochs)).collect();
    let n = runs.len().max(1) as f64;
    let first = &runs[0];
    Trial {
        trial: k,
        point,
        recipe,
        score: seed_scores.iter().sum::<f64>() / n,
        seed_scores: if runs.len() > 1 { seed_scores } else { Vec::new() },
        best_val_accuracy: runs.iter().map(|t| t.best_val_accuracy).sum::<f64>() / n,
        best_epoch: first.best_epoch,
        epochs_run: runs.iter().map(|t| t.history.len()).max().unwrap_or(0),
        final_train_accuracy: runs
            .iter()
            .map(|t| t.history.last().map_or(f64::NAN, |h| h.train_accuracy))
            .fold(f64::INFINITY, f64::min),
        undone_epochs: runs.iter().map(|t| t.history.iter().filter(|h| h.undone).count()).sum(),
        val_accuracy: validated(&first.history),
        seconds: runs.iter().map(|t| t.seconds).sum(),
        shard: shard.to_string(),
        profile: profile.clone(),
    }
}

/// The validation accuracy of each epoch run and kept: one the loss-spike guard undid has none.
fn validated(history: &[learn::train::EpochReport]) -> Vec<f64> {
    history.iter().filter(|h| !h.undone).map(|h| h.val_accuracy).collect()
}

/// A seed's score: its mean validation accuracy over the last `epochs` epochs run and kept.
fn seed_score(history: &[learn::train::EpochReport], epochs: usize) -> f64 {
    let val = validated(history);
    let last = &val[val.len().saturating_sub(epochs)..];
    last.iter().sum::<f64>() / last.len().max(1) as f64
}

/// The combination trial: every dimension at the value of the best trial among the derived
/// point and that dimension's neighbours. `None` when that point was already run (the derived
/// point and the neighbours then say all the search knows).
pub fn combination(trials: &[Trial], base: &SnnRecipe) -> Option<SearchPoint> {
    let d = SearchPoint::derived(base);
    let at_derived = trials.iter().find(|t| t.point == d)?;
    let changed = |p: &SearchPoint| DIMENSIONS.iter().filter(|(differs, _)| differs(p, &d)).count();
    let mut p = d;
    for (differs, take) in DIMENSIONS {
        // the derived point and its neighbours along this dimension alone
        let best = trials
            .iter()
            .filter(|t| differs(&t.point, &d) && changed(&t.point) == 1)
            .fold(at_derived, |b, t| if t.score > b.score { t } else { b });
        p = take(p, &best.point);
    }
    (!trials.iter().any(|t| t.point == p)).then_some(p)
}

/// The search's dimensions: whether two points differ in one, and a point with that dimension
/// taken from another.
type Dimension = (fn(&SearchPoint, &SearchPoint) -> bool, fn(SearchPoint, &SearchPoint) -> SearchPoint);
const DIMENSIONS: [Dimension; 8] = [
    (|a, b| a.tau_scale != b.tau_scale, |a, b| SearchPoint { tau_scale: b.tau_scale, ..a }),
    (|a, b| a.recurrent != b.recurrent, |a, b| SearchPoint { recurrent: b.recurrent, ..a }),
    (|a, b| a.init_gain != b.init_gain, |a, b| SearchPoint { init_gain: b.init_gain, ..a }),
    (|a, b| a.lr != b.lr, |a, b| SearchPoint { lr: b.lr, ..a }),
    (
        |a, b| a.readout_tau_scale != b.readout_tau_scale,
        |a, b| SearchPoint { readout_tau_scale: b.readout_tau_scale, ..a },
    ),
    (|a, b| a.hidden != b.hidden, |a, b| SearchPoint { hidden: b.hidden, ..a }),
    (|a, b| a.dropout != b.dropout, |a, b| SearchPoint { dropout: b.dropout, ..a }),
    (|a, b| a.step_scale != b.step_scale, |a, b| SearchPoint { step_scale: b.step_scale, ..a }),
];

/// Runs the combination trial (numbered after the space's trials) if there is one to run, and
/// logs it to this shard's log in `dir`.
pub fn run_combination(
    data: &SearchData,
    profile: &DataProfile,
    base: &SnnRecipe,
    space: &SearchSpace,
    dir: &Path,
    observer: &mut dyn SearchObserver,
) -> Result<Option<Trial>> {
    let trials = read_logs(dir)?;
    let Some(p) = combination(&trials, base) else { return Ok(None) };
    let k = trials.iter().map(|t| t.trial + 1).max().unwrap_or(0).max(space.trials);
    run_point(data, profile, (k, k + 1), p, base, space, Shard::ALL, &Shard::ALL.log(dir), observer).map(Some)
}

/// The winner of the logged trials: the highest score (ties to the earlier trial).
pub fn winner(trials: &[Trial]) -> Option<&Trial> {
    trials.iter().fold(None, |best: Option<&Trial>, t| match best {
        Some(b) if b.score >= t.score => Some(b),
        _ => Some(t),
    })
}

/// The index of the highest of `scores` (searches' winning validation scores); the first of equals.
pub fn best_score(scores: &[f64]) -> Option<usize> {
    scores.iter().enumerate().fold(None, |best: Option<usize>, (i, &v)| match best {
        Some(b) if scores[b] >= v => Some(b),
        _ => Some(i),
    })
}

/// The winner's recipe for the final models, with `seed`: the whole training split (no
/// hold-out), as many epochs as its trial ran (at least 10), the weights averaged over the last
/// third.
pub fn final_recipe(winner: &Trial, seed: u64) -> SnnRecipe {
    let epochs = winner.epochs_run.max(10);
    SnnRecipe {
        epochs,
        average_epochs: epochs / 3,
        patience: 0,
        val_fraction: 0.0,
        val_seed: None,
        seed,
        ..winner.recipe.clone()
    }
}

/// The trials as a Markdown table, best first marked.
pub fn trials_markdown(trials: &[Trial]) -> String {
    let best = winner(trials).map(|w| w.trial);
    trials_table(trials, |t| if Some(t.trial) == best { " **chosen**" } else { "" })
}

/// A successive-halving search's earlier rungs and how its last was chosen, as Markdown.
fn halving_markdown(h: Halving, space: &SearchSpace, rungs: &[Vec<Trial>], last: &[Trial]) -> String {
    let first = h.first_rung_points(space.trials);
    let mut s = format!(
        "These are the last rung of a successive-halving search (`--search-halving`; Jamieson and Talwalkar 2016): \
         {first} points (the derived one, its neighbours, then draws from the space) for the budget of {} full \
         trials; each rung keeps the best 1 in {} by score and trains them {} times longer. Trial numbers are the \
         points' numbers in the first rung.\n\n| rung | points | epochs at most | score over the last | minutes |\n\
         | --- | --- | --- | --- | --- |\n",
        space.trials, h.eta, h.eta
    );
    for r in 0..h.rungs {
        let rs = h.rung_space(r, space);
        let ran = if r + 1 == h.rungs { last } else { rungs.get(r).map_or(&[][..], |v| &v[..]) };
        s += &format!(
            "| {r} | {} | {} | {} | {:.0} |\n",
            ran.len(),
            rs.epochs,
            rs.score_epochs,
            ran.iter().map(|t| t.seconds).sum::<f64>() / 60.0
        );
    }
    for (r, ran) in rungs.iter().enumerate() {
        let next = promoted(ran, h.rung_points(r + 1, first));
        s += &format!("\n### Rung {r}\n\n");
        s += &trials_table(ran, |t| if next.contains(&t.trial) { " promoted" } else { "" });
    }
    s + "\n### The last rung\n\n"
}

fn trials_table<'a>(trials: &'a [Trial], mark: impl Fn(&'a Trial) -> &'static str) -> String {
    // the step's column only where the trials' steps differ (`--search-step-scale`)
    let steps = trials.iter().any(|t| Some(t.recipe.dt_us) != trials.first().map(|f| f.recipe.dt_us));
    let mut s = format!(
        "| trial | recurrent | hidden | tau_mem (ms) | tau_out (ms) | dropout | lr | init gain |{} epochs run (best) | train acc | val acc, best | score (mean of last) | minutes |\n| --- | --- | --- | --- | --- | --- | --- | --- |{} --- | --- | --- | --- | --- |\n",
        if steps { " step (ms) |" } else { "" },
        if steps { " --- |" } else { "" },
    );
    for t in trials {
        let r = &t.recipe;
        let per: Vec<String> = t.seed_scores.iter().map(|v| format!("{:.1}", 100.0 * v)).collect();
        let score = if per.is_empty() {
            format!("{:.2}%", 100.0 * t.score)
        } else {
            format!("{:.2}% (seeds {})", 100.0 * t.score, per.join(" / "))
        };
        s += &format!(
            "| {}{} | {} | {} | {:.0} | {:.0} | {} | {} | {} |{} {} ({}{}) | {:.1}% | {:.1}% | {} | {:.1} |\n",
            t.trial,
            mark(t),
            if t.point.recurrent { "from zero" } else { "no" },
            t.point.hidden,
            r.tau_mem_us / 1000.0,
            r.tau_out_us / 1000.0,
            t.point.dropout,
            t.point.lr,
            t.point.init_gain,
            if steps { format!(" {} |", r.dt_us as f64 / 1000.0) } else { String::new() },
            t.epochs_run,
            t.best_epoch,
            match t.undone_epochs {
                0 => String::new(),
                n => format!("; {n} undone by the guard"),
            },
            100.0 * t.final_train_accuracy,
            100.0 * t.best_val_accuracy,
            score,
            t.seconds / 60.0
        );
    }
    s
}

/// The winner retrained on the whole training split once per seed (1..=`seeds`). One after the
/// other: burn draws neuron dropout from its device's one seeded generator, so trainings run side
/// by side in one process would not give the same weights twice (measured: three seeds trained
/// in parallel scored 96.67 / 91.48 / 94.07% where one after the other they give 99.63 / 82.22 /
/// 95.93%).
pub fn final_models(
    data: &TactileData,
    winner: &Trial,
    seeds: u64,
    eval_test: EvalTest,
    observer: &mut dyn Observer,
) -> Result<Vec<(u64, TrainedSnn)>> {
    (1..=seeds.max(1))
        .map(|seed| Ok((seed, train_on(&final_recipe(winner, seed), data, eval_test, None, None, observer)?)))
        .collect()
}

/// The search as a Markdown report: the data's profile, the space, the trials, and the final
/// models (their test accuracy only if it was asked for).
pub fn report_markdown(
    profile: &DataProfile,
    space: &SearchSpace,
    rungs: &[Vec<Trial>],
    trials: &[Trial],
    finals: &[(u64, &TrainedSnn)],
) -> String {
    let mut s = format!(
        "# Search on `{}`\n\nGenerated by `braille train --data DIR --search` (docs/training.md). The trials validate on \
         a stratified hold-out of {:.0}% of the training split (seed {}), or on the folder's own validation split; \
         the test split chooses nothing.\n\n## The data\n\n{profile}.\n\n",
        profile.data,
        100.0 * space.val_fraction,
        space.val_seed,
    );
    s += &format!(
        "## The trials\n\nAt most {} epochs each, stopped after {} without a better validation accuracy; the score is \
         the mean validation accuracy over the last {} epochs run{}. Trial 0 is the recipe derived from the data. \
         {} trials, {:.0} minutes, trained {}.\n\n",
        space.epochs,
        space.patience,
        space.score_epochs,
        if space.trial_seeds > 1 { format!(", averaged over {} seeds", space.trial_seeds) } else { String::new() },
        trials.len(),
        trials.iter().map(|t| t.seconds).sum::<f64>() / 60.0,
        match trials.first().map(|t| t.recipe.trainer) {
            Some(TrainerChoice::Sparse) | None => "by the sparse trainer (ours)",
            Some(TrainerChoice::Dense) => "by burn's autodiff (dense)",
        }
    );
    if let Some(h) = space.halving {
        s += &halving_markdown(h, space, rungs, trials);
    }
    if let Some(depth) = trials.first().map(|t| t.recipe.hidden.len()).filter(|&d| d > 1) {
        s += &format!("Every trial has {depth} hidden layers, each of the width the table gives (`--hidden`).\n\n");
    }
    if let Some(f) = trials.first().map(|t| t.recipe.loss_spike_guard).filter(|&f| f > 0.0) {
        s += &format!(
            "Every trial runs with the loss-spike guard (`--loss-spike-guard {f}`): an epoch whose training loss is more \
             than {f} times the lowest before it is undone and the learning rate halved; the table counts the epochs \
             it undid, over all seeds.\n\n"
        );
    }
    s += &trials_markdown(trials);
    if let Some(w) = winner(trials) {
        let f = final_recipe(w, 1);
        s += &format!(
            "\n## The final models\n\nTrial {} retrained once per seed on the whole training split for {} epochs, its \
             weights averaged over the last {}.\n\n| seed | final train accuracy | test accuracy (engine) | minutes |\n\
             | --- | --- | --- | --- |\n",
            w.trial, f.epochs, f.average_epochs
        );
        for (seed, t) in finals {
            s += &format!(
                "| {seed} | {:.1}% | {} | {:.1} |\n",
                100.0 * t.history.last().map_or(f64::NAN, |h| h.train_accuracy),
                t.engine_accuracy.map_or("not looked at".to_string(), |a| format!("{:.2}%", 100.0 * a)),
                t.seconds / 60.0
            );
        }
        let tests: Vec<f64> = finals.iter().filter_map(|(_, t)| t.engine_accuracy).collect();
        if !tests.is_empty() {
            s += &format!(
                "\nMean test accuracy over {} seeds: **{:.2}%**.\n",
                tests.len(),
                100.0 * tests.iter().sum::<f64>() / tests.len() as f64
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An events dataset of 10 training samples lasting 1 s.
    fn events_profile() -> DataProfile {
        DataProfile {
            data: "x".into(),
            kind: "events".into(),
            channels: 3,
            classes: 4,
            train_samples: 10,
            duration_us: 1_000_000,
            events_per_sample: Some(40.0),
            signal_step: None,
            period_us: 0,
        }
    }

    /// A trial as its log would hold it, scored `score`.
    fn logged(trial: usize, point: SearchPoint, recipe: SnnRecipe, score: f64) -> Trial {
        Trial {
            trial,
            point,
            recipe,
            score,
            seed_scores: Vec::new(),
            best_val_accuracy: score,
            best_epoch: 1,
            epochs_run: 1,
            final_train_accuracy: 1.0,
            undone_epochs: 0,
            val_accuracy: vec![score],
            seconds: 1.0,
            shard: "0/1".into(),
            profile: events_profile(),
        }
    }

    #[test]
    fn the_budget_keeps_time_for_the_combination_and_the_final_models() {
        use std::time::Duration;
        let min = |m: f64| Duration::from_secs_f64(60.0 * m);
        let space = SearchSpace::default(); // 3 seeds per trial, 20% held out
        let b = Budget::finishing(min(60.0), &space, 3);
        // the combination, then 3 one-seed final models on 1.25x the samples: 2.25 trials
        assert!((b.reserve_trials - 2.25).abs() < 1e-9, "{}", b.reserve_trials);
        assert!(b.allows(min(61.0), None), "the first trial always starts");
        // 4-minute trials: one more fits until 60 - 4 x 3.25 = 47 minutes
        assert!(b.allows(min(46.9), Some(min(4.0))));
        assert!(!b.allows(min(47.1), Some(min(4.0))));
        // a shard keeps nothing back
        let s = Budget::shard(min(60.0));
        assert!(s.allows(min(55.9), Some(min(4.0))) && !s.allows(min(56.1), Some(min(4.0))));
    }

    #[test]
    fn the_derived_step_alone_draws_the_points_it_drew_before_the_step_was_a_dimension() {
        // raw1350's successive-halving search (2026-12-01): 48 points, 34 of them drawn, logged
        // before the step joined the space
        let log = include_str!("../../../docs/results/search/raw1350-halving/rung-0.jsonl");
        let logged: Vec<Trial> = log.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let d = logged[0].point;
        let base = SnnRecipe {
            recurrent: d.recurrent,
            hidden: vec![d.hidden],
            dropout: d.dropout,
            lr: d.lr,
            init_gain: d.init_gain,
            ..logged[0].recipe.clone()
        };
        let points = SearchSpace { trials: logged.len(), ..SearchSpace::default() }.points(&base);
        assert_eq!(points, logged.iter().map(|t| t.point).collect::<Vec<_>>());
        // and a point at the derived step is written as before, without the field
        let line = serde_json::to_string(&d).unwrap();
        assert!(!line.contains("step_scale"), "{line}");
        assert_eq!(points[0].recipe(&base, &SearchSpace::default()).dt_us, base.dt_us);
    }

    #[test]
    fn a_searched_step_is_a_neighbour_a_draw_and_a_dimension_of_the_combination() {
        let base = SnnRecipe { dt_us: 10_000, ..SnnRecipe::default() };
        let space = SearchSpace { step_scale: vec![1.0, 2.0], trials: 40, ..SearchSpace::default() };
        let pts = space.points(&base);
        let d = SearchPoint::derived(&base);
        // the step's neighbour is the last of the 14 neighbours (3 time constants, recurrence,
        // gain, 2 rates, 2 readouts, 2 sizes, 2 dropouts, then the step), after the dropout's
        let k = pts.iter().position(|p| *p == SearchPoint { step_scale: 2.0, ..d }).unwrap();
        assert_eq!(k, 14);
        assert_ne!(pts[13].dropout, d.dropout);
        let drawn = &pts[k + 1..];
        assert!(drawn.iter().any(|p| p.step_scale == 1.0) && drawn.iter().any(|p| p.step_scale == 2.0));
        let r = pts[k].recipe(&base, &space);
        assert_eq!((r.dt_us, r.tau_mem_us, r.tau_out_us), (20_000, base.tau_mem_us, base.tau_out_us));
        assert!(serde_json::to_string(&pts[k]).unwrap().contains("\"step_scale\":2.0"));
        // the combination takes the step from its best neighbour
        let trial = |k: usize, point: SearchPoint, score: f64| logged(k, point, point.recipe(&base, &space), score);
        let trials = vec![
            trial(0, d, 0.5),
            trial(1, SearchPoint { step_scale: 2.0, ..d }, 0.6),
            trial(2, SearchPoint { lr: 5e-4, ..d }, 0.55),
        ];
        assert_eq!(combination(&trials, &base), Some(SearchPoint { step_scale: 2.0, lr: 5e-4, ..d }));
        // the table gains the step's column only when the steps differ
        assert!(trials_markdown(&trials).contains("| step (ms) |") && trials_markdown(&trials).contains("| 20 |"));
        assert!(!trials_markdown(&trials[..1]).contains("step (ms)"));
        for bad in [0.0, -1.0, f64::NAN] {
            let e = SearchSpace { step_scale: vec![1.0, bad], ..SearchSpace::default() }.check().unwrap_err();
            assert!(e.to_string().contains("step scale"), "{e}");
        }
    }

    #[test]
    fn nice_floor_takes_the_1_2_5_value_below() {
        assert_eq!(nice_floor(13_000.0), 10_000.0);
        assert_eq!(nice_floor(19_999.0), 10_000.0);
        assert_eq!(nice_floor(20_000.0), 20_000.0);
        assert_eq!(nice_floor(7.0), 5.0);
        assert_eq!(nice_floor(0.2), 1.0);
    }

    #[test]
    fn the_derived_recipe_scales_with_the_samples_duration() {
        let p = DataProfile { duration_us: 1_300_000, ..events_profile() };
        let r = derived_recipe(&p);
        assert_eq!(r.dt_us, 10_000);
        assert!((r.tau_mem_us - 108_333.3).abs() < 1.0);
        let slow = derived_recipe(&DataProfile { duration_us: 13_000_000, signal_step: Some(0.5), ..p });
        assert_eq!(slow.dt_us, 100_000);
        assert!((slow.tau_mem_us / r.tau_mem_us - 10.0).abs() < 1e-9);
        assert_eq!(slow.sigma_delta, 0.5);
    }

    #[test]
    fn points_are_distinct_start_at_the_derived_recipe_and_shards_split_them() {
        let base = derived_recipe(&events_profile());
        let space = SearchSpace { trials: 12, ..SearchSpace::default() };
        let pts = space.points(&base);
        assert_eq!(pts.len(), 12);
        assert_eq!(pts[0], SearchPoint::derived(&base));
        assert_eq!(pts, space.points(&base), "the same draw on every shard");
        for (i, p) in pts.iter().enumerate() {
            assert!(!pts[..i].contains(p));
        }
        // the neighbours first: one dimension away from the derived point
        assert_eq!((pts[1].tau_scale, pts[1].hidden), (0.5, 256));
        assert!(pts[1..10].iter().all(|p| p.hidden == 256 && p.dropout == pts[0].dropout));
        // the base's depth is kept, every layer at the point's width
        assert_eq!(pts[1].recipe(&base, &space).hidden, vec![256]);
        let deep = SnnRecipe { hidden: vec![256, 64], ..base.clone() };
        let p = SearchPoint { hidden: 512, ..SearchPoint::derived(&deep) };
        assert_eq!(p.recipe(&deep, &space).hidden, vec![512, 512]);
        let shards: Vec<Shard> = (0..3).map(|i| Shard::parse(&format!("{i}/3")).unwrap()).collect();
        for k in 0..12 {
            assert_eq!(shards.iter().filter(|s| s.runs(k)).count(), 1);
        }
        // the combination: each dimension's best neighbour
        let trial = |k: usize, point: SearchPoint, score: f64| logged(k, point, point.recipe(&base, &space), score);
        let d = pts[0];
        let trials = vec![
            trial(0, d, 0.5),
            trial(1, SearchPoint { tau_scale: 2.0, ..d }, 0.7),
            trial(2, SearchPoint { tau_scale: 4.0, ..d }, 0.6),
            trial(3, SearchPoint { recurrent: false, ..d }, 0.4),
            trial(4, SearchPoint { lr: 2e-3, ..d }, 0.55),
            // two dimensions away: not a neighbour, whatever its score
            trial(5, SearchPoint { hidden: 512, dropout: 0.0, ..d }, 0.9),
        ];
        let c = combination(&trials, &base).unwrap();
        assert_eq!(c, SearchPoint { tau_scale: 2.0, lr: 2e-3, ..d });
        let mut with_c = trials.clone();
        with_c.push(trial(6, c, 0.8));
        assert_eq!(combination(&with_c, &base), None, "already run");
        assert_eq!(winner(&with_c).unwrap().trial, 5);
        // epochs the loss-spike guard undid: counted in the table, kept by the log, absent from
        // the logs of runs without it
        let mut guarded = trial(7, d, 0.5);
        guarded.undone_epochs = 2;
        assert!(trials_markdown(std::slice::from_ref(&guarded)).contains("1 (1; 2 undone by the guard)"));
        assert!(!trials_markdown(&trials).contains("undone"));
        let back: Trial = serde_json::from_str(&serde_json::to_string(&guarded).unwrap()).unwrap();
        assert_eq!(back.undone_epochs, 2);
        assert!(!serde_json::to_string(&trials[0]).unwrap().contains("undone"));
        assert!(Shard::parse("3/3").is_err() && Shard::parse("1").is_err() && Shard::parse("0/0").is_err());
    }

    #[test]
    fn successive_halving_spends_the_budget_of_the_trials_it_replaces() {
        let space = SearchSpace { halving: Some(Halving::DEFAULT), ..SearchSpace::default() };
        let h = Halving::DEFAULT;
        // 16 trials of 60 epochs: 48 points of 7 epochs, 16 of 20, 5 of 60
        let first = h.first_rung_points(space.trials);
        let rungs: Vec<(usize, usize, usize)> = (0..3)
            .map(|r| {
                let rs = h.rung_space(r, &space);
                (h.rung_points(r, first), rs.epochs, rs.score_epochs)
            })
            .collect();
        assert_eq!(rungs, [(48, 7, 1), (16, 20, 2), (5, 60, 5)]);
        let epochs: usize = rungs.iter().map(|(n, e, _)| n * e).sum();
        assert!((epochs as f64 / (16.0 * 60.0) - 1.0).abs() < 0.01, "{epochs}");
        assert_eq!(h.rung_space(2, &space), space, "the last rung is the space itself");
        assert!(SearchSpace { halving: Some(Halving { eta: 1, rungs: 3 }), ..space.clone() }.check().is_err());
        // promotion: the best scores, ties to the earlier point, NaN last
        let t = |trial: usize, score: f64| {
            let recipe = SnnRecipe::preset("default").unwrap();
            logged(trial, SearchPoint::derived(&recipe), recipe, score)
        };
        let ran = [t(0, 0.5), t(1, f64::NAN), t(2, 0.7), t(3, 0.5), t(4, 0.6)];
        assert_eq!(promoted(&ran, 3), [2, 4, 0]);
        assert_eq!(promoted(&ran, 5), [2, 4, 0, 3, 1]);
    }

    #[test]
    fn a_seed_scores_the_epochs_it_kept_not_those_the_guard_undid() {
        let epoch = |epoch, val_accuracy: f64, undone| {
            let mut r = learn::train::EpochReport::without_spikes(
                epoch,
                1e-3,
                (1.0, 1, 1),
                (0.5, val_accuracy),
                std::time::Instant::now(),
            );
            r.undone = undone;
            r
        };
        // epoch 3 undone (no validation): the last two kept are epochs 2 and 4
        let h = [epoch(1, 0.2, false), epoch(2, 0.6, false), epoch(3, f64::NAN, true), epoch(4, 0.8, false)];
        assert_eq!(validated(&h), [0.2, 0.6, 0.8]);
        assert!((seed_score(&h, 2) - 0.7).abs() < 1e-12);
        assert!((seed_score(&h, 10) - 1.6 / 3.0).abs() < 1e-12);
        assert_eq!(seed_score(&h[..2], 1), 0.6);
    }

    #[test]
    fn the_profile_measures_durations_and_the_signal_step_on_the_training_split_only() {
        use encoders::dataset::Sample;
        use encoders::event::{Event, Polarity};
        // analog: 2 channels, 40 frames at 10 ms; channel 0 steps by 3, channel 1 by 0 or 5
        let frames = |n: usize, step: f32| -> Vec<f32> {
            (0..n).flat_map(|k| [3.0 * k as f32, if k % 2 == 0 { 0.0 } else { step }]).collect()
        };
        let sample =
            |id, split, n, step| Sample { id, label: 0, split, data: SampleData::Analog { frames: frames(n, step) } };
        let data = Dataset {
            dir: "sensor_a".into(),
            kind: DatasetKind::Analog,
            classes: vec!["a".into()],
            channels: 2,
            period_us: 10_000,
            samples: vec![
                sample(0, Split::Train, 40, 5.0),
                sample(1, Split::Train, 40, 5.0),
                // the test split is not measured: a longer sample with another step
                sample(2, Split::Test, 400, 50.0),
            ],
        };
        let p = DataProfile::of(&data).unwrap();
        assert_eq!((p.train_samples, p.duration_us, p.kind.as_str()), (2, 400_000, "analog"));
        // steps: 39 of 3 (channel 0) and 39 of 5 (channel 1) per sample: the median is 5
        assert_eq!(p.signal_step, Some(5.0));
        assert_eq!(derived_recipe(&p).sigma_delta, 5.0);
        assert_eq!(derived_recipe(&p).dt_us, 2_000, "400 ms / 100 = 4 ms -> 2 ms");
        // events: the duration is the 95th percentile of the last event's time
        let ev = |id, t_last: i64| Sample {
            id,
            label: 0,
            split: Split::Train,
            data: SampleData::Events(vec![Event::new(0, 0, 0, Polarity::On), Event::new(t_last, 1, 0, Polarity::Off)]),
        };
        let data = Dataset {
            dir: "sensor_b".into(),
            kind: DatasetKind::Events,
            classes: vec!["a".into()],
            channels: 2,
            period_us: 0,
            samples: (0..100).map(|i| ev(i, 1_000 * (i as i64 + 1))).collect(),
        };
        let p = DataProfile::of(&data).unwrap();
        assert_eq!((p.duration_us, p.events_per_sample, p.signal_step), (95_001, Some(2.0), None));
    }
}

/// A whole search as `braille train --data DIR --search` runs it: this shard's trials (none with
/// `run_trials` false, as `--collect` asks), then, when the search ends in this process, the
/// combination trial, the winner, the data re-encoded if the winner's step differs, the final
/// models (one per seed, written beside `out`) and the report (`DIR/search.md`).
#[derive(Debug, Clone)]
pub struct SearchRun<'a> {
    pub dataset: &'a Dataset,
    pub profile: &'a DataProfile,
    /// The recipe the search is centred on (trial 0).
    pub base: &'a SnnRecipe,
    pub space: SearchSpace,
    /// The trials' logs.
    pub dir: PathBuf,
    pub shard: Shard,
    /// Run this shard's trials (false: collect the logs of a finished job array).
    pub run_trials: bool,
    /// The whole search's time budget ([`Budget`]).
    pub budget: Option<std::time::Duration>,
    /// Final models' seeds, 1..=seeds.
    pub seeds: u64,
    pub eval_test: EvalTest,
    /// The model file of seed 1 (seed K: [`seed_path`]).
    pub out: PathBuf,
    pub force: bool,
}

/// A final model written.
#[derive(Debug, Clone)]
pub struct FinalModel {
    pub seed: u64,
    pub path: PathBuf,
    /// Its test accuracy on the engine, only if the test split was asked for.
    pub test_accuracy: Option<f64>,
}

/// What a search gave.
#[derive(Debug, Clone)]
pub enum SearchOutcome {
    /// One shard of a job array: its trials, logged; another process collects them.
    Shard { trials: Vec<Trial> },
    /// The search ended here: every trial, the winner's number, the final models and the report.
    Done { trials: Vec<Trial>, winner: usize, finals: Vec<FinalModel>, report: PathBuf, markdown: String },
}

/// The model file of the final model with `seed` (seed 1 is `out` itself, seed K
/// `OUT.seedK.safetensors`).
pub fn seed_path(out: &Path, seed: u64) -> PathBuf {
    if seed == 1 {
        return out.to_path_buf();
    }
    let stem = out.file_stem().map_or_else(|| "model".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}.seed{seed}.safetensors"))
}

/// Runs the search `run` describes ([`SearchRun`]); trials and final models report to `observer`
/// and `epochs`.
pub fn run(run: &SearchRun, observer: &mut dyn SearchObserver, epochs: &mut dyn Observer) -> Result<SearchOutcome> {
    match search_trials(run, observer)? {
        Trials::Shard(trials) => Ok(SearchOutcome::Shard { trials }),
        Trials::All { data, trials } => finish(run, *data, trials, observer, epochs),
    }
}

/// A search's trials: one shard's, or all of them, the combination included.
enum Trials {
    Shard(Vec<Trial>),
    All { data: Box<TactileData>, trials: Vec<Trial> },
}

/// The checks, this shard's trials and, when the search ends in this process, the combination.
fn search_trials(run: &SearchRun, observer: &mut dyn SearchObserver) -> Result<Trials> {
    run.space.check()?;
    let finishing = !run.run_trials || run.shard.count == 1;
    if finishing {
        for seed in 1..=run.seeds.max(1) {
            let p = seed_path(&run.out, seed);
            if p.exists() && !run.force {
                return Err(Error::Exists { path: p });
            }
        }
    }
    let data = SearchData { dataset: run.dataset, base: TactileData::encode(run.dataset, run.base)? };
    if let Some(h) = run.space.halving
        && run.run_trials
    {
        if run.shard.count != 1 || run.budget.is_some() {
            return Err(Error::SearchLog {
                dir: run.dir.clone(),
                what: "a successive-halving search runs whole and without a budget (its rungs wait for each other; \
                       --search-trials sets its budget)"
                    .into(),
            });
        }
        run_halving(&data, run.profile, run.base, &run.space, h, &run.dir, observer)?;
    } else if run.run_trials {
        let budget = run.budget.map(|total| {
            if finishing { Budget::finishing(total, &run.space, run.seeds) } else { Budget::shard(total) }
        });
        let ran = run_trials(&data, run.profile, run.base, &run.space, run.shard, &run.dir, budget, observer)?;
        if !finishing {
            return Ok(Trials::Shard(ran));
        }
    }
    let trials = read_logs(&run.dir)?;
    if let Some(t) = trials.first()
        && t.profile != *run.profile
    {
        return Err(Error::SearchLog {
            dir: run.dir.clone(),
            what: format!("the trials were run on {}, not on {}", t.profile.data, run.profile.data),
        });
    }
    // each dimension at its best neighbour's value, if that point was not run (not after
    // successive halving, whose last rung is not the derived point's neighbourhood)
    let trials = match run.space.halving {
        None => match run_combination(&data, run.profile, run.base, &run.space, &run.dir, observer)? {
            Some(_) => read_logs(&run.dir)?,
            None => trials,
        },
        Some(_) => trials,
    };
    if trials.is_empty() {
        return Err(Error::SearchLog { dir: run.dir.clone(), what: "no trials logged".into() });
    }
    Ok(Trials::All { data: Box::new(data.base), trials })
}

/// The winner of a finished search's `trials`, its final models and the report.
fn finish(
    run: &SearchRun,
    data: TactileData,
    trials: Vec<Trial>,
    observer: &mut dyn SearchObserver,
    epochs: &mut dyn Observer,
) -> Result<SearchOutcome> {
    let Some(w) = winner(&trials) else {
        return Err(Error::SearchLog { dir: run.dir.clone(), what: "no trials logged".into() });
    };
    observer.chosen(w, &final_recipe(w, 1), run.seeds.max(1));
    let data =
        if SearchData::serves(&data.encoding, &w.recipe) { data } else { TactileData::encode(run.dataset, &w.recipe)? };
    let trained = final_models(&data, w, run.seeds, run.eval_test, epochs)?;
    let mut finals = Vec::new();
    for (seed, t) in &trained {
        let path = seed_path(&run.out, *seed);
        crate::train::fit::save_model(&t.model, &path, run.force)?;
        let f = FinalModel { seed: *seed, path, test_accuracy: t.engine_accuracy };
        observer.final_model(&f);
        finals.push(f);
    }
    let refs: Vec<(u64, &TrainedSnn)> = trained.iter().map(|(s, t)| (*s, t)).collect();
    let rungs = match run.space.halving {
        Some(h) => (0..h.rungs - 1).map(|r| read_rung_log(&run.dir, r)).collect::<Result<Vec<_>>>()?,
        None => Vec::new(),
    };
    let markdown = report_markdown(run.profile, &run.space, &rungs, &trials, &refs);
    let report = run.dir.join("search.md");
    std::fs::write(&report, &markdown).map_err(|source| Error::Io { path: report.clone(), source })?;
    let winner = w.trial;
    Ok(SearchOutcome::Done { trials, winner, finals, report, markdown })
}

/// The steps the fixed rule's searches try, as multiples of the derived step (the space's
/// `step_scale`): the derived step and twice it, since #51's tenth leave-one-dataset-out decision
/// (2026-12-01, docs/log/tactile-2026-12-01.md: on validation raw1350 +0.28, th10 0.00, the taxels
/// -0.42, none losing more than 0.5). `braille train --search --both-gradients` uses them unless
/// `--search-step-scale` says otherwise; a plain `--search` keeps the derived step alone.
pub const RULE_STEP_SCALE: [f64; 2] = [1.0, 2.0];

/// The searches of the rule issue #51's leave-one-dataset-out decisions fixed (docs/training.md):
/// `runs` (the same space, with truncated and with exact gradients, each with its own trial
/// log) searched in turn, and only the one whose winner has the highest validation score (the
/// first of equals) trains its final models (and reads the test split, if asked). Returns which
/// search stood, every search's winning score, and its outcome. Not for shards or budgets: a
/// budget would give the searches different trials.
pub fn run_rule(
    runs: &[SearchRun],
    observer: &mut dyn SearchObserver,
    epochs: &mut dyn Observer,
) -> Result<(usize, Vec<f64>, SearchOutcome)> {
    let mut done = Vec::new();
    for r in runs {
        if r.shard.count != 1 || r.budget.is_some() {
            return Err(Error::SearchLog {
                dir: r.dir.clone(),
                what: "the searches of the fixed rule run whole and without a budget (give --search-trials)".into(),
            });
        }
        let Trials::All { data, trials } = search_trials(r, observer)? else {
            unreachable!("an unsharded search ends in this process")
        };
        done.push((data, trials));
    }
    let scores: Vec<f64> = done.iter().map(|(_, t)| winner(t).map_or(f64::NEG_INFINITY, |w| w.score)).collect();
    let Some(chosen) = best_score(&scores) else {
        return Err(Error::SearchLog { dir: PathBuf::new(), what: "no search to run".into() });
    };
    let (data, trials) = done.swap_remove(chosen);
    let outcome = finish(&runs[chosen], *data, trials, observer, epochs)?;
    Ok((chosen, scores, outcome))
}
