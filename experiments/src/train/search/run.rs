//! A whole search as `braille train --data DIR --search` runs it, from the trials to the final
//! models and the report; and the rule that runs searches at two step scales.

use super::*;

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

/// The line of a final model: its seed, its test accuracy where the test split was looked at, its file.
impl std::fmt::Display for FinalModel {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self.test_accuracy {
            Some(a) => write!(f, "seed {}: test accuracy on the engine {:.2}%", self.seed, 100.0 * a)?,
            None => write!(f, "seed {}: test split not looked at (--eval-test)", self.seed)?,
        }
        write!(f, "; wrote {}", self.path.display())
    }
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
pub(super) enum Trials {
    Shard(Vec<Trial>),
    All { data: Box<TactileData>, trials: Vec<Trial> },
}

/// The checks, this shard's trials and, when the search ends in this process, the combination.
pub(super) fn search_trials(run: &SearchRun, observer: &mut dyn SearchObserver) -> Result<Trials> {
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
pub(super) fn finish(
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
