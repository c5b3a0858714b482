//! Running trials: the budget, the shard's trials, successive halving's rungs, the combination
//! trial and the winner.

use super::*;

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

pub(super) struct EpochsTo<'a>(&'a mut dyn SearchObserver);
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
pub(super) fn run_listed(
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
pub(super) fn promoted(trials: &[Trial], keep: usize) -> Vec<usize> {
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
    pub(super) fn serves(a: &TactileEncoding, b: &SnnRecipe) -> bool {
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
pub(super) fn run_point(
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

pub(super) fn trial_of(
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
pub(super) fn validated(history: &[learn::train::EpochReport]) -> Vec<f64> {
    history.iter().filter(|h| !h.undone).map(|h| h.val_accuracy).collect()
}

/// A seed's score: its mean validation accuracy over the last `epochs` epochs run and kept.
pub(super) fn seed_score(history: &[learn::train::EpochReport], epochs: usize) -> f64 {
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
pub(super) type Dimension = (fn(&SearchPoint, &SearchPoint) -> bool, fn(SearchPoint, &SearchPoint) -> SearchPoint);
pub(super) const DIMENSIONS: [Dimension; 8] = [
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
