//! Conventional networks on a tactile dataset (`braille baselines --data DIR --search`): a GRU,
//! an LSTM and a temporal CNN over the binned events ([`learn::temporal`]), each chosen by the
//! same validation-driven protocol as the SNN's search ([`crate::train::search`]): trials on
//! the training split less a stratified validation hold-out (or the folder's own validation
//! split), the winner per network retrained on the whole training split once per seed for the
//! winning trial's best epoch count, the test split scored only when asked.

use crate::error::Result;
use crate::train::fit::{EvalTest, TactileData};
use learn::data::SpikeSet;
use learn::temporal::{TemporalConfig, TemporalKind, TrainedTemporal};
use learn::train::{Observer, TrainConfig};
use serde::Serialize;
use std::time::{Duration, Instant};

/// What the search tries and how long it may take.
#[derive(Debug, Clone, PartialEq)]
pub struct NetworkSearch {
    pub kinds: Vec<TemporalKind>,
    /// Epochs per trial (the best validation epoch is kept; `patience` epochs without a gain
    /// stop it).
    pub epochs: usize,
    pub patience: usize,
    /// Final models' seeds, 1..=seeds.
    pub seeds: u64,
    /// The whole search's time (trials and final models): a trial starts only while the trials'
    /// mean time, and the final models' estimated time, still fit.
    pub budget: Option<Duration>,
    /// Bin widths tried, in microseconds (at least one step each).
    pub bins_us: Vec<i64>,
}

impl Default for NetworkSearch {
    fn default() -> Self {
        NetworkSearch {
            kinds: vec![TemporalKind::Tcn, TemporalKind::Gru, TemporalKind::Lstm],
            epochs: 60,
            patience: 15,
            seeds: 3,
            budget: None,
            bins_us: vec![20_000, 50_000],
        }
    }
}

/// The training settings of every trial and final model of `kind` (fixed, not searched).
pub fn train_config(kind: TemporalKind, epochs: usize, patience: usize, seed: u64) -> TrainConfig {
    TrainConfig {
        epochs,
        // 64, not the SNN's 32: burn's per-operation cost on small matrices dominates a
        // recurrent network's step, and half the batches halve an epoch's time
        batch_size: 64,
        lr: 3e-3,
        lr_final_fraction: 0.05,
        seed,
        patience,
        // recurrent networks: the norm clipped, as is usual for them
        clip_norm: if kind == TemporalKind::Tcn { 0.0 } else { 1.0 },
        ..TrainConfig::default()
    }
}

/// The points tried for `kind` on data of step `dt_us`, the first the centre: each bin width of
/// the search with a small and a larger network.
pub fn points(kind: TemporalKind, dt_us: i64, bins_us: &[i64]) -> Vec<TemporalConfig> {
    let widths: &[usize] = match kind {
        TemporalKind::Tcn => &[32, 64],
        _ => &[64, 128],
    };
    let mut out = Vec::new();
    for &bin in bins_us {
        for &hidden in widths {
            out.push(TemporalConfig {
                kind,
                hidden,
                blocks: 4,
                kernel: 3,
                steps_per_bin: (bin / dt_us.max(1)).max(1) as usize,
                dropout: 0.1,
            });
        }
    }
    out
}

/// One trial.
#[derive(Debug, Clone, Serialize)]
pub struct NetworkTrial {
    pub config: TemporalConfig,
    pub val_accuracy: f64,
    pub best_epoch: usize,
    pub epochs_run: usize,
    pub final_train_accuracy: f64,
    pub seconds: f64,
}

/// One final model.
#[derive(Debug, Clone, Serialize)]
pub struct NetworkFinal {
    pub seed: u64,
    pub train_accuracy: f64,
    pub test_accuracy: Option<f64>,
    pub seconds: f64,
}

/// A network's search and final models.
#[derive(Debug, Clone, Serialize)]
pub struct NetworkResult {
    pub kind: TemporalKind,
    pub trials: Vec<NetworkTrial>,
    /// The winning trial (index into `trials`); `None` if the budget allowed none.
    pub winner: Option<usize>,
    pub finals: Vec<NetworkFinal>,
    pub parameters: usize,
    pub macs_per_sample: u64,
}

impl NetworkResult {
    pub fn chosen(&self) -> Option<&NetworkTrial> {
        self.winner.map(|w| &self.trials[w])
    }

    /// Mean and sample standard deviation of the final models' test accuracy (if looked at).
    pub fn test_mean_sd(&self) -> Option<(f64, f64)> {
        let t: Vec<f64> = self.finals.iter().filter_map(|f| f.test_accuracy).collect();
        crate::eval::scoring::mean_sd(&t)
    }
}

/// Hears about the search as it goes.
pub trait NetworkObserver {
    fn trial(&mut self, _kind: TemporalKind, _trial: &NetworkTrial) {}
    fn skipped(&mut self, _kind: TemporalKind, _config: &TemporalConfig) {}
    fn final_model(&mut self, _kind: TemporalKind, _f: &NetworkFinal) {}
}

impl NetworkObserver for () {}

/// Runs the search on `data` (validation as the SNN search: `val_fraction`, `val_seed`).
pub fn search(
    data: &TactileData,
    val_fraction: f64,
    val_seed: u64,
    s: &NetworkSearch,
    eval_test: EvalTest,
    observer: &mut dyn NetworkObserver,
    epochs: &mut dyn Observer,
) -> Result<Vec<NetworkResult>> {
    let (train, val) = data.hold_out(val_fraction, val_seed)?;
    let started = Instant::now();
    let dt_us = data.train.dt_us;
    // the trials of every network in turn, the centres first
    let grids: Vec<Vec<TemporalConfig>> = s.kinds.iter().map(|&k| points(k, dt_us, &s.bins_us)).collect();
    let rounds = grids.iter().map(Vec::len).max().unwrap_or(0);
    let mut trials: Vec<Vec<NetworkTrial>> = vec![Vec::new(); s.kinds.len()];
    for round in 0..rounds {
        for (k, grid) in grids.iter().enumerate() {
            let Some(cfg) = grid.get(round) else { continue };
            if !fits(s, started.elapsed(), &trials, k, data.train.len() as f64 / train.len().max(1) as f64) {
                observer.skipped(cfg.kind, cfg);
                continue;
            }
            let t = run_trial(cfg, &train, &val, s, epochs);
            observer.trial(cfg.kind, &t);
            trials[k].push(t);
        }
    }
    let mut out = Vec::new();
    for (k, &kind) in s.kinds.iter().enumerate() {
        let trials = std::mem::take(&mut trials[k]);
        let winner = winner(&trials);
        let mut finals = Vec::new();
        let (mut parameters, mut macs) = (0, 0);
        if let Some(w) = winner {
            let cfg = trials[w].config;
            let classes = data.train.classes.len();
            parameters = cfg.parameters(data.train.n_inputs, classes);
            macs = cfg.macs_per_sample(data.train.n_inputs, classes, data.train.steps);
            for seed in 1..=s.seeds.max(1) {
                let f = final_model(&cfg, trials[w].best_epoch, data, seed, eval_test, epochs);
                observer.final_model(kind, &f);
                finals.push(f);
            }
        }
        out.push(NetworkResult { kind, trials, winner, finals, parameters, macs_per_sample: macs });
    }
    Ok(out)
}

/// Whether trial `kind`'s next trial fits the budget: its expected time (its network's mean
/// trial, or the mean of all trials for a network's first) and the expected time of the final
/// models of every network tried so far, this one included (per trial: its time per epoch times
/// its best epoch, scaled to the whole training split, per seed). A network not tried reserves
/// nothing: its first trial runs only if its final models fit too.
fn fits(s: &NetworkSearch, elapsed: Duration, trials: &[Vec<NetworkTrial>], kind: usize, scale: f64) -> bool {
    let Some(budget) = s.budget else { return true };
    let all: Vec<NetworkTrial> = trials.iter().flatten().cloned().collect();
    if all.is_empty() {
        return true;
    }
    let mean = |t: &[NetworkTrial], f: &dyn Fn(&NetworkTrial) -> f64| t.iter().map(f).sum::<f64>() / t.len() as f64;
    let finals = |t: &[NetworkTrial]| {
        mean(t, &|t| t.seconds / t.epochs_run.max(1) as f64 * t.best_epoch.max(5) as f64)
            * scale
            * s.seeds.max(1) as f64
    };
    let first = trials[kind].is_empty();
    let next = if first { mean(&all, &|t| t.seconds) } else { mean(&trials[kind], &|t| t.seconds) };
    let reserved: f64 = trials.iter().filter(|t| !t.is_empty()).map(|t| finals(t)).sum::<f64>()
        + if first { finals(&all) } else { 0.0 };
    elapsed.as_secs_f64() + next + reserved <= budget.as_secs_f64()
}

fn run_trial(
    cfg: &TemporalConfig,
    train: &SpikeSet,
    val: &SpikeSet,
    s: &NetworkSearch,
    epochs: &mut dyn Observer,
) -> NetworkTrial {
    let started = Instant::now();
    let t = learn::temporal::train(cfg, train, Some(val), &train_config(cfg.kind, s.epochs, s.patience, 1), epochs);
    trial_of(&t, started.elapsed())
}

fn trial_of(t: &TrainedTemporal, took: Duration) -> NetworkTrial {
    NetworkTrial {
        config: t.config,
        val_accuracy: t.best_val_accuracy,
        best_epoch: t.best_epoch,
        epochs_run: t.history.len(),
        final_train_accuracy: t.history.last().map_or(f64::NAN, |h| h.train_accuracy),
        seconds: took.as_secs_f64(),
    }
}

/// The best validation accuracy (ties to the earlier, smaller trial).
pub fn winner(trials: &[NetworkTrial]) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, t) in trials.iter().enumerate() {
        if best.is_none_or(|b| t.val_accuracy > trials[b].val_accuracy) {
            best = Some(i);
        }
    }
    best
}

/// The winner retrained on the whole training split for its best epoch count (at least 5), no
/// validation.
fn final_model(
    cfg: &TemporalConfig,
    best_epoch: usize,
    data: &TactileData,
    seed: u64,
    eval_test: EvalTest,
    epochs: &mut dyn Observer,
) -> NetworkFinal {
    let started = Instant::now();
    let t = learn::temporal::train(cfg, &data.train, None, &train_config(cfg.kind, best_epoch.max(5), 0, seed), epochs);
    let (_, train_accuracy, _) = t.evaluate(&data.train);
    let test_accuracy = (eval_test == EvalTest::Yes).then(|| t.evaluate(&data.test).1);
    NetworkFinal { seed, train_accuracy, test_accuracy, seconds: started.elapsed().as_secs_f64() }
}

/// The trials of every network as a Markdown table, each network's chosen trial marked.
pub fn trials_markdown(results: &[NetworkResult]) -> String {
    let mut s = String::from(
        "| network | trial | bin (steps) | hidden / channels | epochs run (best) | train acc (last epoch) | validation | minutes |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for r in results {
        for (i, t) in r.trials.iter().enumerate() {
            s += &format!(
                "| {} | {}{} | {} | {} | {} ({}) | {:.1}% | {:.1}% | {:.1} |\n",
                r.kind.name(),
                i,
                if Some(i) == r.winner { " **chosen**" } else { "" },
                t.config.steps_per_bin,
                t.config.hidden,
                t.epochs_run,
                t.best_epoch,
                100.0 * t.final_train_accuracy,
                100.0 * t.val_accuracy,
                t.seconds / 60.0
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trial(val: f64, seconds: f64) -> NetworkTrial {
        NetworkTrial {
            config: points(TemporalKind::Gru, 10_000, &[20_000])[0],
            val_accuracy: val,
            best_epoch: 5,
            epochs_run: 5,
            final_train_accuracy: 1.0,
            seconds,
        }
    }

    #[test]
    fn points_bin_at_the_asked_widths_and_start_at_the_centre() {
        let p = points(TemporalKind::Tcn, 10_000, &[20_000, 50_000]);
        assert_eq!(
            p.iter().map(|c| (c.steps_per_bin, c.hidden)).collect::<Vec<_>>(),
            [(2, 32), (2, 64), (5, 32), (5, 64)]
        );
        // a bin never narrower than a step
        assert_eq!(points(TemporalKind::Gru, 40_000, &[20_000])[0].steps_per_bin, 1);
    }

    #[test]
    fn the_winner_is_the_best_validation_and_ties_go_to_the_earlier_trial() {
        assert_eq!(winner(&[trial(0.5, 1.0), trial(0.7, 1.0), trial(0.7, 1.0)]), Some(1));
        assert_eq!(winner(&[]), None);
    }

    #[test]
    fn the_budget_keeps_time_for_the_final_models_of_every_network_tried() {
        let s = NetworkSearch { budget: Some(Duration::from_secs(100)), seeds: 3, ..NetworkSearch::default() };
        // one network tried: a 10 s trial of 5 epochs, best at 5 -> 10 s per final model, 30 s
        let ran = vec![vec![trial(0.5, 10.0)], vec![]];
        // its next trial: 10 s and its finals' 30 s
        assert!(fits(&s, Duration::from_secs(60), &ran, 0, 1.0));
        assert!(!fits(&s, Duration::from_secs(61), &ran, 0, 1.0));
        // the other network's first trial reserves its own finals too: 10 + 30 + 30
        assert!(fits(&s, Duration::from_secs(30), &ran, 1, 1.0));
        assert!(!fits(&s, Duration::from_secs(31), &ran, 1, 1.0));
        // finals on a training split 1.25x the trials' take longer
        assert!(!fits(&s, Duration::from_secs(60), &ran, 0, 1.25));
        // without a budget, always
        assert!(fits(&NetworkSearch::default(), Duration::from_secs(1_000_000), &ran, 1, 1.0));
    }
}
