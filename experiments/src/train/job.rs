//! One training run as `braille train` asks for it: the recipe (named, or derived from a dataset
//! folder's profile) with its keys set ([`TrainJob::prepare`]), then either one model trained and
//! saved ([`train`]) or the validation-driven search ([`search`]), with the checks that refuse
//! options that do not go together.

use crate::train::fit::{DistillFrom, EvalTest, TactileData, TrainedSnn, save_model, train_on, train_windows};
use crate::train::recipe::{SnnRecipe, TrainerChoice, sweep};
use crate::train::resnet::{ResnetPreset, ResnetTraining, TrainedResnet, train_resnet};
use crate::train::search::{DataProfile, SearchObserver, SearchOutcome, SearchRun, Shard, derived_recipe};
use crate::train::settings::TrainSettings;
use crate::{Error, Progress, Result};
use encoders::dataset::Dataset;
use learn::train::Observer;
use pipeline::preprocess::Preprocess;
use snn::model_file::Arch;
use std::path::PathBuf;

/// What to train, on what, and where the model goes (with the `clap` feature, `braille train`'s
/// arguments).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct TrainJob {
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "snn"))]
    pub arch: Arch,
    /// A dataset folder in the iCub Braille layout (events: samples.csv, events.csv, split.csv;
    /// analog: raw.csv, split.csv). Without it, both architectures train on simulated windows.
    #[cfg_attr(feature = "clap", arg(long))]
    pub data: Option<PathBuf>,
    /// The SNN's recipe: a preset (default, raw1350, th10, chars, words, segment, cells,
    /// cells-segment, xylo, speck) or a recipe file, JSON or TOML (missing fields take the
    /// defaults). Without it, with --data: the recipe derived from the data (docs/training.md);
    /// without --data: `default`.
    #[cfg_attr(feature = "clap", arg(long))]
    pub recipe: Option<String>,
    /// KEY=VALUE over the recipe, in order: any recipe field (`lr=0.001`, `hidden=128,64`,
    /// `neuron=cuba-lif`, `distill.from=A,B`, `braille=ueb-g2`) or search option (`search.trials=32`,
    /// `search.step_scale=1,2`, `search.both_gradients=true`); `--print-recipe` shows the keys
    /// and their values (docs/training.md). The earlier flags of each key (`--lr 0.001`) still
    /// work.
    #[cfg_attr(feature = "clap", arg(long = "set", value_name = "KEY=VALUE"))]
    pub set: Vec<String>,
    /// ResNet: the network's size.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "lite"))]
    pub preset: ResnetPreset,
    /// ResNet: the paper's input configuration.
    #[cfg_attr(feature = "clap", arg(long = "aug", value_enum, default_value = "normaug"))]
    pub preprocess: Preprocess,
    /// Train either architecture on a lab's recordings folder (docs/recordings.md) instead of
    /// simulated scans: its `train` scans cut into windows by the paper's labeling pipeline (the
    /// character count from each line's `text`, durations from its `speed_mm_s`), its `val` scans
    /// to choose checkpoints. The recipe's scans, seed of scans and word rows do not apply.
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "data"))]
    pub recordings: Option<PathBuf>,
    /// Start from this trained model's weights (fine-tuning; its network, input and classes must
    /// be the recipe's, but for how its neurons reset: a subtracting model fine-tunes into its
    /// twin with `reset=zero`), e.g. a shipped model fine-tuned on a lab's recordings, or a
    /// float model fine-tuned for a chip (`chip=xylo`; with --data, its neurons may differ from
    /// the recipe's).
    #[cfg_attr(feature = "clap", arg(long))]
    pub init: Option<PathBuf>,
    /// Score the test split after training (by default the test split is not looked at).
    #[cfg_attr(feature = "clap", arg(long))]
    pub eval_test: bool,
    /// Model file to write.
    #[cfg_attr(feature = "clap", arg(long, required_unless_present_any = ["print_recipe", "print_boards"]))]
    pub out: Option<PathBuf>,
    /// Replace an existing model file.
    #[cfg_attr(feature = "clap", arg(long))]
    pub force: bool,
    /// Write the per-epoch history as JSON here.
    #[cfg_attr(feature = "clap", arg(long))]
    pub history: Option<PathBuf>,
}

/// A job's recipe with its keys set, and the dataset folder it trains on, loaded, with its profile.
pub struct Prepared {
    pub settings: TrainSettings,
    pub dataset: Option<Dataset>,
    pub profile: Option<DataProfile>,
}

impl TrainJob {
    /// The model file to write.
    pub fn out(&self) -> Result<&std::path::Path> {
        self.out.as_deref().ok_or_else(|| Error::Options("--out: no model file to write".into()))
    }

    /// Whether the test split is scored.
    pub fn eval_test(&self) -> EvalTest {
        if self.eval_test { EvalTest::Yes } else { EvalTest::No }
    }

    /// Loads the dataset (for the SNN) at the step the keys give, profiles it, and sets the keys
    /// over the named recipe, else the one derived from the profile, else `default`.
    pub fn prepare(&self) -> Result<Prepared> {
        let named = self.recipe.as_deref().map(SnnRecipe::load).transpose()?;
        let dataset = match (&self.data, self.arch) {
            (Some(d), Arch::Snn) => {
                // the period the keys give, else the named recipe's, else the default's
                let s = TrainSettings::with(named.clone().unwrap_or_default(), &self.set)?;
                Some(Dataset::load(d, s.recipe.period_us)?)
            }
            _ => None,
        };
        let profile = dataset.as_ref().map(DataProfile::of).transpose()?;
        let base = named.or_else(|| profile.as_ref().map(derived_recipe)).unwrap_or_default();
        Ok(Prepared { settings: TrainSettings::with(base, &self.set)?, dataset, profile })
    }
}

/// A refusal of options that do not go together.
fn refuse<T>(what: impl Into<String>) -> Result<T> {
    Err(Error::Options(what.into()))
}

/// A model trained by [`train`], saved.
pub enum Trained {
    Snn(TrainedSnn),
    Resnet(TrainedResnet),
}

impl std::fmt::Display for Trained {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            Trained::Snn(t) => write!(f, "{t}"),
            Trained::Resnet(t) => write!(f, "{t}"),
        }
    }
}

/// Trains one model as the job asks and saves it (with its history, when asked).
pub fn train(job: &TrainJob, p: &Prepared, epochs: &mut dyn Observer, progress: &dyn Progress) -> Result<Trained> {
    let (s, r) = (&p.settings, &p.settings.recipe);
    if DistillFrom::of(r).is_some() && (job.arch != Arch::Snn || job.data.is_none()) {
        return refuse(
            "distill.from trains an SNN on a dataset folder (--arch snn --data DIR), without --search or --collect",
        );
    }
    if s.given("search") {
        return refuse("the search.* keys set how --search searches; pass --search (or --collect)");
    }
    let out = job.out()?;
    if out.exists() && !job.force {
        return Err(Error::Exists { path: out.to_path_buf() });
    }
    let recordings = job.recordings.as_deref().map(corpus::recordings::Recordings::open).transpose()?;
    let init = job.init.as_deref();
    let trained = match (job.arch, &p.dataset) {
        (Arch::Resnet, _) if job.data.is_some() => {
            return refuse("the ResNet trains on simulated character windows; --data is for the SNN");
        }
        (Arch::Resnet, _) => {
            if s.given("trainer") || s.given("gradient_cutoff") {
                return refuse("trainer and gradient_cutoff choose how an SNN is trained; the ResNet trains on burn");
            }
            if s.given("train_builds") {
                return refuse("train_builds: the ResNet trains on the training builds (1-4)");
            }
            let t = ResnetTraining {
                preset: job.preset,
                preprocess: job.preprocess,
                task: r.task,
                jitter_ms: r.jitter_ms,
                blank_cells: r.blank_cells,
                // the ResNet's own default: the labeler's grid as it is
                pool: if s.given("pool") { r.pool } else { 1 },
                crop_rows: r.crop_rows,
                band_rows: r.band_rows,
                trials: r.trials,
                word_rows: r.word_rows,
                letter_rows: r.letter_rows,
                pair_rows: r.pair_rows,
                sweep: sweep(&r.train_speeds_mm_s, &r.train_depths_mm, &r.train_levels),
                denoise: r.denoise,
                cells: r.cells,
                realism: r.realism,
                train: r.train_config(),
            };
            let m = train_resnet(&t, recordings.as_ref(), init, epochs, progress)?;
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
            }
            m.model.save(out, job.force)?;
            if let Some(h) = &job.history {
                crate::write_json(h, &m.history, job.force)?;
            }
            return Ok(Trained::Resnet(m));
        }
        (Arch::Snn, None) => train_windows(r, recordings.as_ref(), init, epochs, progress)?,
        (Arch::Snn, Some(dataset)) => {
            if s.given("crop_rows") || s.given("band_rows") {
                return refuse(
                    "crop_rows and band_rows crop simulated windows; a dataset folder's taxels are the input as they are",
                );
            }
            if s.given("train_levels") || s.given("denoise") {
                return refuse(
                    "train_levels and denoise shape simulated scans' events; a dataset folder's taxels are the input as they are",
                );
            }
            if s.given("train_builds") {
                return refuse(
                    "train_builds chooses the sensors of simulated scans; a dataset folder is recorded data",
                );
            }
            let data = TactileData::encode(dataset, r)?;
            train_on(r, &data, job.eval_test(), init, DistillFrom::of(r).as_ref(), epochs)?
        }
    };
    save_model(&trained.model, out, job.force)?;
    if let Some(h) = &job.history {
        crate::write_json(h, &trained.history, job.force)?;
    }
    Ok(Trained::Snn(trained))
}

/// How a search runs: in this process, a shard of a job array, or the collection of a job
/// array's logs (with the `clap` feature, `braille train`'s search arguments).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct SearchJob {
    /// With --data: a validation-driven search around the derived recipe (on a hold-out of the
    /// training split), then the winner retrained on the whole training split once per seed.
    #[cfg_attr(feature = "clap", arg(long = "search"))]
    pub run_trials: bool,
    /// Pick the winner from the trial logs in DIR (all shards) and train the final models.
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "run_trials"))]
    pub collect: Option<PathBuf>,
    /// --search: the folder of the trial logs [default: OUT with the extension `.search`].
    #[cfg_attr(feature = "clap", arg(long))]
    pub search_dir: Option<PathBuf>,
    /// --search: the whole search's time budget, in minutes: a trial starts only if it, the
    /// combination trial and the final models are expected to end within it (each trial taking
    /// the mean time of those run so far). With --shard: the shard's trials only.
    #[cfg_attr(feature = "clap", arg(long))]
    pub budget_min: Option<f64>,
    /// --search / --collect: the final models' seeds, 1..=K (the first is written to --out, seed K
    /// to OUT.seedK.safetensors).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1))]
    pub seeds: u64,
    /// --search: run every N-th trial from I only, log it and stop (a job array's task I of N);
    /// then `--collect DIR` picks the winner from every shard's log.
    #[cfg_attr(feature = "clap", arg(long))]
    pub shard: Option<String>,
}

impl SearchJob {
    /// Whether the job searches (or collects a search's logs).
    pub fn wanted(&self) -> bool {
        self.run_trials || self.collect.is_some()
    }
}

/// What a search ended with.
pub enum Searched {
    /// The fixed rule's two searches (`search.both_gradients`): the one that stands (0 the
    /// truncated-gradient search, 1 the exact), both validation scores, and its outcome.
    Rule { chosen: usize, scores: Vec<f64>, outcome: SearchOutcome },
    /// One search: this shard's trials, or all and the final models; where its logs are.
    One { shard: Shard, dir: PathBuf, outcome: SearchOutcome },
}

/// The validation-driven search around the job's recipe on its dataset folder, then the final
/// models (or this shard's trials only, or the collection of a job array's logs).
pub fn search(
    job: &TrainJob,
    how: &SearchJob,
    p: &Prepared,
    observer: &mut dyn SearchObserver,
    epochs: &mut dyn Observer,
) -> Result<Searched> {
    let (settings, base) = (&p.settings, &p.settings.recipe);
    let (Some(dataset), Some(profile), Arch::Snn) = (&p.dataset, &p.profile, job.arch) else {
        return refuse("--search and --collect need --data (a tactile dataset folder) and the SNN");
    };
    if DistillFrom::of(base).is_some() {
        return refuse(
            "distill.from trains an SNN on a dataset folder (--arch snn --data DIR), without --search or --collect",
        );
    }
    if let Some(m) = how.budget_min
        && !(m.is_finite() && m >= 0.0)
    {
        return refuse(format!("--budget-min: expected a number of minutes, 0 or more, got {m}"));
    }
    let out = job.out()?;
    let dir = how.collect.clone().or_else(|| how.search_dir.clone()).unwrap_or_else(|| out.with_extension("search"));
    let sharded = how.shard.is_some() || how.budget_min.is_some();
    if settings.search.both_gradients && (sharded || settings.given("gradient_cutoff")) {
        return refuse(
            "search.both_gradients runs both searches whole, at its own gradients: not with --shard, --budget-min or gradient_cutoff",
        );
    }
    if settings.search.halving && sharded {
        return refuse("search.halving runs its rungs whole: not with --shard or --budget-min");
    }
    let run = |base, dir| SearchRun {
        dataset,
        profile,
        base,
        space: settings.search.space(),
        dir,
        shard: Shard::ALL,
        run_trials: how.run_trials,
        budget: how.budget_min.map(|m| std::time::Duration::from_secs_f64(60.0 * m)),
        seeds: how.seeds,
        eval_test: job.eval_test(),
        out: out.to_path_buf(),
        force: job.force,
    };
    if settings.search.both_gradients {
        if base.trainer != TrainerChoice::Sparse || base.gradient_cutoff <= 0.0 {
            return refuse(format!(
                "search.both_gradients: its first search is the sparse trainer's truncated one, but this recipe has the {:?} trainer with gradient cutoff {}",
                base.trainer, base.gradient_cutoff
            ));
        }
        // the fixed rule's second search
        let exact = SnnRecipe { gradient_cutoff: 0.0, ..base.clone() };
        let runs = [run(base, dir.join("truncated")), run(&exact, dir.join("exact"))];
        let (chosen, scores, outcome) = crate::train::search::run_rule(&runs, observer, epochs)?;
        return Ok(Searched::Rule { chosen, scores, outcome });
    }
    let shard = how.shard.as_deref().map(Shard::parse).transpose()?.unwrap_or(Shard::ALL);
    let run = SearchRun { shard, ..run(base, dir.clone()) };
    Ok(Searched::One { shard, dir, outcome: crate::train::search::run(&run, observer, epochs)? })
}
