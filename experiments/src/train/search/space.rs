//! The search space around the derived recipe: its points, its dimensions and successive halving.

use super::*;

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

pub(super) fn unit() -> f64 {
    1.0
}

pub(super) fn is_unit(v: &f64) -> bool {
    *v == 1.0
}

pub(super) fn units() -> Vec<f64> {
    vec![1.0]
}

pub(super) fn are_units(v: &[f64]) -> bool {
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
pub(super) fn scaled_step(dt_us: i64, scale: f64) -> i64 {
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

    pub(super) fn factor(&self, rungs_after: usize) -> usize {
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

    pub(super) fn check(&self) -> Result<()> {
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

    pub(super) fn check(&self) -> Result<()> {
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
