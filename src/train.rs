//! `braille train`: trains a classifier and saves it as a model file. The SNN starts from a
//! recipe (`--recipe NAME|FILE.json|FILE.toml`, `experiments::train::recipe`) whose fields, and
//! the search's options, `--set KEY=VALUE` overrides (`experiments::train::settings`).

use crate::common::{Bar, Epochs};
use anyhow::{Result, bail};
use encoders::dataset::Dataset;
use experiments::train::fit::{DistillFrom, EvalTest, TactileData, train_on};
use experiments::train::recipe::{SnnRecipe, TrainerChoice};
use experiments::train::resnet::{ResnetPreset, ResnetTraining};
use experiments::train::search::{
    DataProfile, FinalModel, SearchObserver, SearchOutcome, SearchRun, Shard, Trial, derived_recipe, trials_markdown,
};
use experiments::train::settings::TrainSettings;
use pipeline::preprocess::Preprocess;
use snn::model_file::Arch;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    #[arg(long, value_enum, default_value = "snn")]
    arch: Arch,
    /// A dataset folder in the iCub Braille layout (events: samples.csv, events.csv, split.csv;
    /// analog: raw.csv, split.csv). Without it, both architectures train on simulated windows.
    #[arg(long)]
    data: Option<PathBuf>,
    /// The SNN's recipe: a preset (default, raw1350, th10, chars, words, segment, cells,
    /// cells-segment, xylo, speck) or a recipe file, JSON or TOML (missing fields take the
    /// defaults). Without it, with --data: the recipe derived from the data (docs/training.md);
    /// without --data: `default`.
    #[arg(long)]
    recipe: Option<String>,
    /// KEY=VALUE over the recipe, in order: any recipe field (`lr=0.001`, `hidden=128,64`,
    /// `neuron=cuba-lif`, `distill.from=A,B`, `braille=ueb-g2`) or search option (`search.trials=32`,
    /// `search.step_scale=1,2`, `search.both_gradients=true`); `--print-recipe` shows the keys
    /// and their values (docs/training.md). The earlier flags of each key (`--lr 0.001`) still
    /// work.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// With --data: a validation-driven search around the derived recipe (on a hold-out of the
    /// training split), then the winner retrained on the whole training split once per seed.
    #[arg(long)]
    search: bool,
    /// --search: the whole search's time budget, in minutes: a trial starts only if it, the
    /// combination trial and the final models are expected to end within it (each trial taking
    /// the mean time of those run so far). With --shard: the shard's trials only.
    #[arg(long)]
    budget_min: Option<f64>,
    /// --search / --collect: the final models' seeds, 1..=K (the first is written to --out, seed K
    /// to OUT.seedK.safetensors).
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// --search: run every N-th trial from I only, log it and stop (a job array's task I of N);
    /// then `--collect DIR` picks the winner from every shard's log.
    #[arg(long)]
    shard: Option<String>,
    /// Pick the winner from the trial logs in DIR (all shards) and train the final models.
    #[arg(long, conflicts_with = "search")]
    collect: Option<PathBuf>,
    /// --search: the folder of the trial logs [default: OUT with the extension `.search`].
    #[arg(long)]
    search_dir: Option<PathBuf>,
    /// Score the test split after training (by default the test split is not looked at).
    #[arg(long)]
    eval_test: bool,
    /// Print the recipe the keys make, as JSON (each field a key), and stop.
    #[arg(long)]
    print_recipe: bool,
    /// Without --data: print the simulated training boards the recipe scans (each board's name,
    /// then its rows as printed), and stop.
    #[arg(long, conflicts_with = "data")]
    print_boards: bool,
    /// ResNet: the network's size.
    #[arg(long, value_enum, default_value = "lite")]
    preset: ResnetPreset,
    /// ResNet: the paper's input configuration.
    #[arg(long, value_enum, default_value = "normaug")]
    aug: Preprocess,
    /// Train either architecture on a lab's recordings folder (docs/recordings.md) instead of
    /// simulated scans: its `train` scans cut into windows by the paper's labeling pipeline (the
    /// character count from each line's `text`, durations from its `speed_mm_s`), its `val` scans
    /// to choose checkpoints. The recipe's scans, seed of scans and word rows do not apply.
    #[arg(long, conflicts_with = "data")]
    recordings: Option<PathBuf>,
    /// Start from this trained model's weights (fine-tuning; its network, input and classes must
    /// be the recipe's, but for how its neurons reset: a subtracting model fine-tunes into its
    /// twin with `reset=zero`), e.g. a shipped model fine-tuned on a lab's recordings, or a
    /// float model fine-tuned for a chip (`chip=xylo`; with --data, its neurons may differ from
    /// the recipe's).
    #[arg(long)]
    init: Option<PathBuf>,
    /// Model file to write.
    #[arg(long, required_unless_present_any = ["print_recipe", "print_boards"])]
    out: Option<PathBuf>,
    /// Replace an existing model file.
    #[arg(long)]
    force: bool,
    /// Write the per-epoch history as JSON here.
    #[arg(long)]
    history: Option<PathBuf>,
    /// No progress bars (a line per epoch still).
    #[arg(long)]
    quiet: bool,
}

/// The flags `braille train` took before its options became keys, where the key has another name:
/// each `--flag VALUE` reads as `--set key=VALUE`, a switch (`--bias`) as `key=true`.
const FLAG_KEYS: [(&str, &str); 13] = [
    ("words", "word_rows"),
    ("train-speeds", "train_speeds_mm_s"),
    ("train-depths", "train_depths_mm"),
    ("freeze-layers", "frozen_layers"),
    ("search-trials", "search.trials"),
    ("search-epochs", "search.epochs"),
    ("trial-seeds", "search.trial_seeds"),
    ("search-halving", "search.halving"),
    ("search-step-scale", "search.step_scale"),
    ("both-gradients", "search.both_gradients"),
    ("distill-from", "distill.from"),
    ("distill-weight", "distill.weight"),
    ("distill-temperature", "distill.temperature"),
];

/// `argv` with `braille train`'s earlier flags written as `--set` (the flags of `braille train
/// --help` and any other command's arguments pass as they are).
pub fn flags_as_keys(argv: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    // `braille train ...`: the command is the first argument (the binary has no global options)
    let at = 1;
    if argv.get(at).is_none_or(|a| a != "train") {
        return argv;
    }
    let run_flags: Vec<String> = <Args as clap::Args>::augment_args(clap::Command::new("train"))
        .get_arguments()
        .filter_map(|a| a.get_long().map(str::to_string))
        .collect();
    // any other long flag names a key: renamed as the table says, else `-` read as `_` (one
    // that names no key is refused by the settings, naming it)
    let key_of = |flag: &str| -> Option<String> {
        if flag == "help" || run_flags.iter().any(|f| f == flag) {
            return None;
        }
        let renamed = FLAG_KEYS.iter().find(|(f, _)| *f == flag).map(|(_, k)| k.to_string());
        Some(renamed.unwrap_or_else(|| flag.replace('-', "_")))
    };
    let mut out: Vec<std::ffi::OsString> = argv[..=at].to_vec();
    let mut rest = argv[at + 1..].iter().peekable();
    while let Some(arg) = rest.next() {
        let Some(flag) = arg.to_str().and_then(|a| a.strip_prefix("--")) else {
            out.push(arg.clone());
            continue;
        };
        let (name, inline) = match flag.split_once('=') {
            Some((n, v)) => (n, Some(v.to_string())),
            None => (flag, None),
        };
        let Some(key) = key_of(name) else {
            out.push(arg.clone());
            continue;
        };
        let value = match inline {
            Some(v) => v,
            // the next argument is the value (`--bias true`), unless it is a flag or there is none:
            // then a switch (`--bias`)
            None => match rest.next_if(|v| !v.to_str().is_some_and(|v| v.starts_with("--"))) {
                Some(v) => v.to_string_lossy().into_owned(),
                None => "true".into(),
            },
        };
        out.push("--set".into());
        out.push(format!("{key}={value}").into());
    }
    out
}

pub fn run(args: Args) -> Result<()> {
    // a dataset folder: its profile, and the recipe derived from it when none is named
    let named = args.recipe.as_deref().map(SnnRecipe::load).transpose()?;
    let dataset = match (&args.data, args.arch) {
        (Some(d), Arch::Snn) => {
            // the period the keys give, else the named recipe's, else the default's
            let s = TrainSettings::with(named.clone().unwrap_or_default(), &args.set)?;
            Some(Dataset::load(d, s.recipe.period_us)?)
        }
        _ => None,
    };
    let profile = dataset.as_ref().map(DataProfile::of).transpose()?;
    let settings =
        TrainSettings::with(named.or_else(|| profile.as_ref().map(derived_recipe)).unwrap_or_default(), &args.set)?;
    let r = &settings.recipe;
    if args.print_recipe {
        if let Some(p) = &profile {
            eprintln!("{p}");
        }
        println!("{}", serde_json::to_string_pretty(r)?);
        eprintln!("search options (keys search.*): {}", serde_json::to_string(&settings.search)?);
        return Ok(());
    }
    if args.print_boards {
        for board in corpus::windows::training_boards(&r.training_scans())? {
            let (rows, spread) = board.rows();
            let kind = if spread { "letters spread over the row" } else { "at the cell spacing" };
            let name = if matches!(board, sim::BoardKind::Text(_)) { "text".into() } else { board.name() };
            println!("# {name} ({} rows, {kind})", rows.len());
            rows.iter().for_each(|row| println!("{row}"));
        }
        return Ok(());
    }
    let out = args.out.clone().expect("clap requires --out");
    let distill = DistillFrom::of(r);
    if distill.is_some() && (args.arch != Arch::Snn || args.data.is_none() || args.search || args.collect.is_some()) {
        bail!("distill.from trains an SNN on a dataset folder (--arch snn --data DIR), without --search or --collect");
    }
    if settings.given("search") && !args.search && args.collect.is_none() {
        bail!("the search.* keys set how --search searches; pass --search (or --collect)");
    }
    if args.search || args.collect.is_some() {
        let (Some(dataset), Some(profile)) = (&dataset, &profile) else {
            bail!("--search and --collect need --data (a tactile dataset folder) and the SNN");
        };
        return search(&args, &settings, dataset, profile, &out);
    }
    if out.exists() && !args.force {
        bail!("{}: exists; pass --force to replace it", out.display());
    }
    let eval_test = if args.eval_test { EvalTest::Yes } else { EvalTest::No };
    let mut epochs = Epochs::new(args.quiet);
    let bar = Bar::default();
    let trained = match (args.arch, &args.data) {
        (Arch::Resnet, Some(_)) => bail!("the ResNet trains on simulated character windows; --data is for the SNN"),
        (Arch::Resnet, None) => {
            if settings.given("trainer") || settings.given("gradient_cutoff") {
                bail!("trainer and gradient_cutoff choose how an SNN is trained; the ResNet trains on burn");
            }
            if settings.given("train_builds") {
                bail!("train_builds: the ResNet trains on the training builds (1-4)");
            }
            let t = ResnetTraining {
                preset: args.preset,
                preprocess: args.aug,
                task: r.task,
                jitter_ms: r.jitter_ms,
                blank_cells: r.blank_cells,
                // the ResNet's own default: the labeler's grid as it is
                pool: if settings.given("pool") { r.pool } else { 1 },
                crop_rows: r.crop_rows,
                band_rows: r.band_rows,
                trials: r.trials,
                word_rows: r.word_rows,
                letter_rows: r.letter_rows,
                pair_rows: r.pair_rows,
                sweep: experiments::train::recipe::sweep(&r.train_speeds_mm_s, &r.train_depths_mm),
                cells: r.cells,
                realism: r.realism,
                train: r.train_config(),
            };
            let rec = args.recordings.as_deref().map(corpus::recordings::Recordings::open).transpose()?;
            let m =
                experiments::train::resnet::train_resnet(&t, rec.as_ref(), args.init.as_deref(), &mut epochs, &bar)?;
            eprint!("{m}");
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            m.model.save(&out, args.force)?;
            if let Some(h) = &args.history {
                experiments::write_json(h, &m.history, args.force)?;
            }
            eprintln!("wrote {}", out.display());
            return Ok(());
        }
        (Arch::Snn, None) => {
            let rec = args.recordings.as_deref().map(corpus::recordings::Recordings::open).transpose()?;
            experiments::train::fit::train_windows(r, rec.as_ref(), args.init.as_deref(), &mut epochs, &bar)?
        }
        (Arch::Snn, Some(_)) => {
            if settings.given("crop_rows") || settings.given("band_rows") {
                bail!(
                    "crop_rows and band_rows crop simulated windows; a dataset folder's taxels are the input as they are"
                );
            }
            if settings.given("train_builds") {
                bail!("train_builds chooses the sensors of simulated scans; a dataset folder is recorded data");
            }
            let dataset = dataset.as_ref().expect("loaded above for the SNN");
            if args.recipe.is_none()
                && let Some(p) = &profile
            {
                eprintln!("{p}; the recipe derived from it (--print-recipe shows it)");
            }
            let data = TactileData::encode(dataset, r)?;
            train_on(r, &data, eval_test, args.init.as_deref(), distill.as_ref(), &mut epochs)?
        }
    };
    eprint!("{trained}");
    experiments::train::fit::save_model(&trained.model, &out, args.force)?;
    if let Some(h) = &args.history {
        experiments::write_json(h, &trained.history, args.force)?;
    }
    eprintln!("wrote {} (peak RSS {:.0} MB)", out.display(), experiments::peak_rss_mb().unwrap_or(f64::NAN));
    Ok(())
}

/// Reports each trial as it ends (and its epochs, unless quiet).
struct TrialLines {
    quiet: bool,
}

impl SearchObserver for TrialLines {
    fn rung_begin(&mut self, rung: usize, rungs: usize, points: usize, epochs: usize) {
        eprintln!("successive halving, rung {rung} of {rungs}: {points} points, at most {epochs} epochs each");
    }
    fn trial_begin(&mut self, trial: usize, of: usize, r: &SnnRecipe) {
        eprintln!(
            "trial {trial}/{of}: hidden {:?}{}, tau_mem {:.0} ms, tau_out {:.0} ms, dropout {}, lr {}, init gain {}, step {} ms",
            r.hidden,
            if r.recurrent { " recurrent from zero" } else { " feed-forward" },
            r.tau_mem_us / 1000.0,
            r.tau_out_us / 1000.0,
            r.dropout,
            r.lr,
            r.init_gain,
            r.dt_us as f64 / 1000.0
        );
    }
    fn epoch(&mut self, e: &learn::train::EpochReport) {
        if !self.quiet {
            eprintln!(
                "  epoch {:>3}: train acc {:5.1}% | val acc {:5.1}% | {:.1} s",
                e.epoch,
                100.0 * e.train_accuracy,
                100.0 * e.val_accuracy,
                e.seconds
            );
        }
    }
    fn chosen(&mut self, w: &Trial, f: &SnnRecipe, seeds: u64) {
        eprintln!(
            "chosen: trial {} (score {:.2}%); training it on the whole training split for {} epochs (averaged over the last {}), seeds 1..={seeds}",
            w.trial,
            100.0 * w.score,
            f.epochs,
            f.average_epochs,
        );
    }

    fn final_model(&mut self, m: &FinalModel) {
        eprintln!(
            "seed {}: {}; wrote {}",
            m.seed,
            m.test_accuracy.map_or("test split not looked at (--eval-test)".into(), |a| format!(
                "test accuracy on the engine {:.2}%",
                100.0 * a
            )),
            m.path.display()
        );
    }

    fn trial_end(&mut self, t: &Trial) {
        eprintln!(
            "trial {}: score {:.2}% (best {:.2}% at epoch {} of {}), {:.1} min",
            t.trial,
            100.0 * t.score,
            100.0 * t.best_val_accuracy,
            t.best_epoch,
            t.epochs_run,
            t.seconds / 60.0
        );
    }
}

/// `--search` (this shard's trials, then, unsharded, the final models) and `--collect`, run by
/// [`experiments::train::search::run`]; this prints what it returns.
fn search(args: &Args, settings: &TrainSettings, dataset: &Dataset, profile: &DataProfile, out: &Path) -> Result<()> {
    let base = &settings.recipe;
    if let Some(m) = args.budget_min
        && !(m.is_finite() && m >= 0.0)
    {
        bail!("--budget-min: expected a number of minutes, 0 or more, got {m}");
    }
    let dir = args.collect.clone().or_else(|| args.search_dir.clone()).unwrap_or_else(|| out.with_extension("search"));
    let both = settings.search.both_gradients;
    if both && (args.shard.is_some() || args.budget_min.is_some() || settings.given("gradient_cutoff")) {
        bail!(
            "search.both_gradients runs both searches whole, at its own gradients: not with --shard, --budget-min or gradient_cutoff"
        );
    }
    if settings.search.halving && (args.shard.is_some() || args.budget_min.is_some()) {
        bail!("search.halving runs its rungs whole: not with --shard or --budget-min");
    }
    // the fixed rule's second search (search.both_gradients)
    let exact = SnnRecipe { gradient_cutoff: 0.0, ..base.clone() };
    let run = |base, dir| SearchRun {
        dataset,
        profile,
        base,
        space: settings.search.space(),
        dir,
        shard: Shard::ALL,
        run_trials: args.search,
        budget: args.budget_min.map(|m| std::time::Duration::from_secs_f64(60.0 * m)),
        seeds: args.seeds,
        eval_test: if args.eval_test { EvalTest::Yes } else { EvalTest::No },
        out: out.to_path_buf(),
        force: args.force,
    };
    if both {
        if base.trainer != TrainerChoice::Sparse || base.gradient_cutoff <= 0.0 {
            bail!(
                "search.both_gradients: its first search is the sparse trainer's truncated one, but this recipe has the {:?} trainer with gradient cutoff {}",
                base.trainer,
                base.gradient_cutoff
            );
        }
        let runs = [run(base, dir.join("truncated")), run(&exact, dir.join("exact"))];
        eprintln!("{profile}");
        let (chosen, scores, outcome) = experiments::train::search::run_rule(
            &runs,
            &mut TrialLines { quiet: args.quiet },
            &mut Epochs::new(args.quiet),
        )?;
        let name = ["truncated", "exact"];
        eprintln!(
            "the {}-gradient search stands: validation score {:.2}% against {:.2}% ({})",
            name[chosen],
            100.0 * scores[chosen],
            100.0 * scores[1 - chosen],
            name[1 - chosen]
        );
        if let SearchOutcome::Done { trials, report, .. } = outcome {
            println!("{}", trials_markdown(&trials));
            eprintln!("wrote {}", report.display());
        }
        return Ok(());
    }
    let run = SearchRun {
        shard: args.shard.as_deref().map(Shard::parse).transpose()?.unwrap_or(Shard::ALL),
        ..run(base, dir)
    };
    eprintln!("{profile}");
    match experiments::train::search::run(&run, &mut TrialLines { quiet: args.quiet }, &mut Epochs::new(args.quiet))? {
        SearchOutcome::Shard { trials } => {
            println!("{}", trials_markdown(&trials));
            eprintln!(
                "shard {}: {} trials in {}; when every shard is done: braille train --data {} --collect {} --out {}",
                run.shard,
                trials.len(),
                run.dir.display(),
                dataset.dir.display(),
                run.dir.display(),
                out.display()
            );
        }
        SearchOutcome::Done { trials, report, .. } => {
            println!("{}", trials_markdown(&trials));
            eprintln!("wrote {}", report.display());
        }
    }
    Ok(())
}
