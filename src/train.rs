//! `braille train`: trains a classifier and saves it as a model file. The SNN starts from a
//! recipe (`--recipe NAME|FILE.json`, `experiments::train::recipe`) whose fields the flags override.

use crate::common::{Bar, Epochs};
use anyhow::{Context, Result, bail};
use corpus::windows::Task;
use encoders::dataset::Dataset;
use experiments::train::fit::{EvalTest, TactileData, train_on};
use experiments::train::recipe::{NeuronChoice, ReadoutGradient, SnnRecipe, SurrogateChoice, TrainerChoice};
use experiments::train::resnet::{ResnetPreset, ResnetTraining};
use experiments::train::search::{
    DataProfile, FinalModel, Halving, SearchObserver, SearchOutcome, SearchRun, SearchSpace, Shard, Trial,
    derived_recipe, trials_markdown,
};
use pipeline::augment::Preprocess;
use snn::model_file::{Arch, Readout};
use snn::neuron::Reset;
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
    /// cells-segment, xylo, speck) or a JSON file of
    /// one (missing fields take the defaults); the flags below override its fields. Without it,
    /// with --data: the recipe derived from the data (docs/training.md); without --data: `default`.
    #[arg(long)]
    recipe: Option<String>,
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
    /// --search: trials at most (trial 0 is the derived recipe).
    #[arg(long, default_value_t = 16)]
    search_trials: usize,
    /// --search: epochs at most per trial (each stops early after 15 without a better
    /// validation accuracy).
    #[arg(long, default_value_t = 60)]
    search_epochs: usize,
    /// --search: seeds per trial; a trial's score is their mean (a recipe that trains well only
    /// with some seeds loses), and the final models train for the most epochs any of them ran.
    #[arg(long, default_value_t = 3)]
    trial_seeds: u64,
    /// --search: successive halving (docs/training.md): 3x --search-trials points in three rungs,
    /// each keeping the best third for three times the epochs, at about the same cost as
    /// --search-trials full trials; no combination trial.
    #[arg(long, requires = "search", conflicts_with_all = ["shard", "budget_min"])]
    search_halving: bool,
    /// --search / --collect: the SNN's step searched too, at these multiples of the derived
    /// step (as the conventional networks search their bins; the data re-encoded at each), e.g.
    /// `1,2` [default: 1, the derived step only; with --both-gradients 1,2, the fixed rule's].
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    search_step_scale: Vec<f64>,
    /// --search: run every N-th trial from I only, log it and stop (a job array's task I of N);
    /// then `--collect DIR` picks the winner from every shard's log.
    #[arg(long)]
    shard: Option<String>,
    /// Pick the winner from the trial logs in DIR (all shards) and train the final models.
    #[arg(long, conflicts_with = "search")]
    collect: Option<PathBuf>,
    /// --search: the rule issue #51 fixed (docs/training.md): the space, its step at 1 and 2
    /// times the derived one, searched twice, with truncated gradients (the recipe's cutoff; logs
    /// in DIR/truncated) and with exact ones (DIR/exact); only the better by validation score
    /// trains the final models.
    #[arg(long, requires = "search", conflicts_with_all = ["gradient_cutoff", "shard", "budget_min"])]
    both_gradients: bool,
    /// --search: the folder of the trial logs [default: OUT with the extension `.search`].
    #[arg(long)]
    search_dir: Option<PathBuf>,
    /// Score the test split after training (by default the test split is not looked at).
    #[arg(long)]
    eval_test: bool,
    /// Print the recipe the flags make, as JSON, and stop.
    #[arg(long)]
    print_recipe: bool,
    /// Without --data: print the simulated training boards the recipe scans (each board's name,
    /// then its rows as printed), and stop.
    #[arg(long, conflicts_with = "data")]
    print_boards: bool,
    /// Without --data: the Braille code of the training boards: `grade1-letters` (the paper's
    /// letters: SAB, UN and letter and word rows) or `ueb-g1`/`ueb-g2` (every cell in seeded
    /// orders and rows of UEB print; a character classifier then learns the 63 cells)
    /// [recipe: `cells` and `cells-segment` ueb-g2, the others grade1-letters].
    #[arg(long, value_enum)]
    braille: Option<pipeline::code::BrailleCode>,
    /// Without --data: what to learn from the simulated windows.
    #[arg(long, value_enum)]
    task: Option<Task>,
    /// Without --data, character windows: also each window shifted by this many ms either way
    /// (at 8 mm/s), as a streaming reader meets them (0: the paper's aligned windows only).
    #[arg(long)]
    jitter_ms: Option<f64>,
    /// Without --data, segmentation: every blank cell (word spaces, a pitch or two past the
    /// row's ends) is background as well [recipe: `segment` since 2026-11-25].
    #[arg(long)]
    blank_cells: Option<bool>,
    /// Without --data: the simulator's nuisances (training sensor builds beyond `clean`)
    /// [recipe: nominal].
    #[arg(long, value_enum)]
    realism: Option<sim::Realism>,
    /// ResNet: the network's size.
    #[arg(long, value_enum, default_value = "lite")]
    preset: ResnetPreset,
    /// ResNet: the paper's input configuration.
    #[arg(long, value_enum, default_value = "normaug")]
    aug: Preprocess,
    /// Without --data: simulated scans per board row (SAB and UN, 8 mm/s, 1.5 mm) [recipe: 10].
    #[arg(long)]
    trials: Option<u64>,
    /// Without --data: rows of random words (TextBlob's frequent words, none of the EV board's)
    /// added to the training boards (0: the paper's protocol, SAB and UN only).
    #[arg(long)]
    words: Option<usize>,
    /// Without --data: rows of training words that hold every letter at every place in a row
    /// (the row's start, a later word's start, inside a word, a word's end) this many times,
    /// added to the training boards (0: none).
    #[arg(long)]
    letter_rows: Option<usize>,
    /// Without --data: passes of letter strings that hold every ordered pair of letters inside a
    /// word (the neighbours a character's window sees), added to the training boards (0: none).
    #[arg(long)]
    pair_rows: Option<usize>,
    /// Without --data: training scans spread over these speeds (mm/s), one pairing with
    /// `--train-depths` per trial (trial k at speed k mod S, depth (k / S) mod D) [the recipe's;
    /// the paper's: 8].
    #[arg(long, value_delimiter = ',')]
    train_speeds: Option<Vec<f64>>,
    /// Without --data: training scans spread over these depths (mm) [the recipe's; the paper's:
    /// 1.5].
    #[arg(long, value_delimiter = ',')]
    train_depths: Option<Vec<f64>>,
    /// Train either architecture on a lab's recordings folder (docs/recordings.md) instead of
    /// simulated scans: its `train` scans cut into windows by the paper's labeling pipeline (the
    /// character count from each line's `text`, durations from its `speed_mm_s`), its `val` scans
    /// to choose checkpoints. The recipe's scans, seed of scans and word rows do not apply.
    #[arg(long, conflicts_with = "data")]
    recordings: Option<PathBuf>,
    /// Start from this trained model's weights (fine-tuning; its network, input and classes must
    /// be the recipe's, but for how its neurons reset: a subtracting model fine-tunes into its
    /// twin with `--reset zero`), e.g. a shipped model fine-tuned on a lab's recordings, or a
    /// float model fine-tuned for a chip (--chip; with --data, its neurons may differ from the
    /// recipe's).
    #[arg(long)]
    init: Option<PathBuf>,
    /// Knowledge distillation (Hinton et al. 2015; a dataset folder, the sparse trainer): each
    /// training sample also learns from this trained SNN's logits on it (run on the engine, each
    /// sample encoded as that model was trained), e.g. a twin that resets to zero taught by its
    /// subtracting headline; several models, comma separated, teach as an ensemble (their softened
    /// distributions averaged). Validation and checkpoints stay the cross-entropy's.
    #[arg(long, value_delimiter = ',', requires = "data", conflicts_with_all = ["search", "collect"])]
    distill_from: Vec<PathBuf>,
    /// The distillation term's share of the loss, in [0, 1].
    #[arg(long, default_value_t = 0.5, requires = "distill_from")]
    distill_weight: f32,
    /// The distillation's temperature: both networks' logits divided by it before the softmax.
    #[arg(long, default_value_t = 4.0, requires = "distill_from")]
    distill_temperature: f32,
    /// Simulated windows: sum-pooling of the 64x80 crop [default: the recipe's (2) for the SNN, 1
    /// for the ResNet].
    #[arg(long)]
    pool: Option<usize>,
    /// Simulated windows (the SNN, the lite and tiny ResNets): the pooled rows of the labeler's
    /// 120 kept in the crop, first and last plus one [default: 28,92].
    #[arg(long, value_delimiter = ',')]
    crop_rows: Option<Vec<usize>>,
    /// Simulated windows, with a centring input (the SNN's `--center true`, the ResNet's `norm` and
    /// `normaug`): the pooled rows the vertical centring looks in, first and last plus one, wider
    /// than the crop's, so that a row the board's yaw moves past the crop is centred back whole
    /// [default: the crop's rows].
    #[arg(long, value_delimiter = ',')]
    band_rows: Option<Vec<usize>>,
    /// SNN on simulated windows: centre each window vertically.
    #[arg(long)]
    center: Option<bool>,
    /// Sampling period of analog data, in microseconds (the iCub taxels: 40 Hz).
    #[arg(long)]
    period_us: Option<i64>,
    /// Sigma-delta threshold for analog data, in the signal's units.
    #[arg(long)]
    sigma_delta: Option<f32>,
    /// Place sigma-delta events at the interpolated crossing time.
    #[arg(long)]
    interpolate: bool,
    /// Simulation step, in microseconds [recipe: 10000].
    #[arg(long)]
    dt_us: Option<i64>,
    /// Hidden layer sizes, comma separated [recipe: 256].
    #[arg(long, value_delimiter = ',')]
    hidden: Option<Vec<usize>>,
    #[arg(long, value_enum)]
    neuron: Option<NeuronChoice>,
    /// Membrane time constant of hidden neurons, in microseconds.
    #[arg(long)]
    tau_mem_us: Option<f64>,
    /// Synaptic time constant (CubaLIF), in microseconds.
    #[arg(long)]
    tau_syn_us: Option<f64>,
    /// Membrane time constant of the leaky-integrator readout, in microseconds.
    #[arg(long)]
    tau_out_us: Option<f64>,
    /// Biases in the hidden layers.
    #[arg(long)]
    bias: bool,
    /// How hidden neurons reset after a spike. NIR (and so the chips) can only express `zero`.
    #[arg(long, value_enum)]
    reset: Option<Reset>,
    /// Clip the gradient norm to this (0: off).
    #[arg(long)]
    clip_norm: Option<f64>,
    /// Ramp the learning rate up linearly over the first this many optimiser steps (0: off).
    #[arg(long)]
    warmup_steps: Option<usize>,
    /// Recurrent connections in the hidden layers.
    #[arg(long)]
    recurrent: bool,
    #[arg(long, value_enum)]
    readout: Option<Readout>,
    /// Max-membrane readout: how the clamp of the readout at zero backpropagates.
    #[arg(long, value_enum)]
    readout_gradient: Option<ReadoutGradient>,
    #[arg(long, value_enum)]
    surrogate: Option<SurrogateChoice>,
    /// Surrogate sharpness: fast-sigmoid slope, arctan alpha or triangle width.
    #[arg(long)]
    surrogate_scale: Option<f32>,
    /// Weight scale at initialisation (times PyTorch's 1/sqrt(fan_in)).
    #[arg(long)]
    init_gain: Option<f32>,
    /// With --recurrent: the recurrent weights' scale at initialisation (default: --init-gain; 0
    /// starts the network feed-forward and lets training grow the recurrence).
    #[arg(long)]
    recurrent_init_gain: Option<f32>,
    #[arg(long)]
    epochs: Option<usize>,
    /// Augmentation: probability of dropping each input event in training.
    #[arg(long)]
    drop_events: Option<f64>,
    /// Augmentation: time stretched by a factor in 1 +- this, per training sample.
    #[arg(long)]
    stretch: Option<f64>,
    /// Augmentation: each input event moved by whole steps within +- this many microseconds.
    #[arg(long)]
    event_jitter_us: Option<i64>,
    /// Decoupled weight decay (AdamW), per unit of learning rate (0: plain Adam).
    #[arg(long)]
    weight_decay: Option<f64>,
    /// Class-balanced sampling: each class's share of an epoch in proportion to its windows'
    /// count to the power 1 - P (0: every window once; 0.5: square-root sampling; 1: every class
    /// alike); the epoch's length unchanged. SNN and ResNet.
    #[arg(long, value_name = "P")]
    class_balance: Option<f64>,
    /// Fine-tuning (with --init): L2-SP, each step's pull toward the starting model's weights,
    /// per unit of learning rate (0: off; the sparse trainer).
    #[arg(long)]
    anchor_decay: Option<f64>,
    /// Undo an epoch whose mean training loss is more than F times the lowest of the epochs
    /// before it, and halve the learning rate for the rest of the run (0: off, the default): a
    /// guard against a run that collapses halfway (docs/training.md).
    #[arg(long, value_name = "F")]
    loss_spike_guard: Option<f64>,
    /// Layers that keep their starting weights, comma separated (0 the first; the sparse
    /// trainer), e.g. `--freeze-layers 0` to fine-tune the readout alone in a one-hidden-layer
    /// network.
    #[arg(long, value_delimiter = ',')]
    freeze_layers: Option<Vec<usize>>,
    /// Stochastic weight averaging over the last this many epochs (0: off).
    #[arg(long)]
    average_epochs: Option<usize>,
    /// Which trainer computes the SNN's gradients: sparse (ours, on spike lists) or dense (burn's
    /// autodiff, the reference) [recipe: sparse].
    #[arg(long, value_enum)]
    trainer: Option<TrainerChoice>,
    /// The sparse trainer's truncation: surrogate derivatives below this fraction of their peak
    /// count as zero; 0 gives exact gradients [recipe: 0.01].
    #[arg(long)]
    gradient_cutoff: Option<f32>,
    /// Quantisation-aware training for this chip: the chip's decays and reset, every forward
    /// pass in the chip's arithmetic, checkpoints chosen on the chip's validation accuracy
    /// (docs/chips.md); with --init, a trained float model fine-tuned for the chip.
    #[arg(long)]
    chip: Option<snn::chip::Chip>,
    /// The chip's weight quantiser in quantisation-aware training [recipe: global].
    #[arg(long, value_enum)]
    chip_quantisation: Option<snn::chip::xylo::Quantisation>,
    /// A diagnostic: on the first and the last epoch, every batch's truncated gradient is
    /// compared with the exact one on the same samples (cosine, relative error; printed with the
    /// epoch). The weights trained are the same as without it.
    #[arg(long)]
    check_truncation: bool,
    /// Neuron dropout in training, per hidden neuron and sample (0: off).
    #[arg(long)]
    dropout: Option<f64>,
    #[arg(long)]
    batch_size: Option<usize>,
    #[arg(long)]
    lr: Option<f64>,
    /// Share of the training split held out for validation (0: none).
    #[arg(long)]
    val_fraction: Option<f64>,
    /// Stop after this many epochs without a better validation accuracy (0: never).
    #[arg(long)]
    patience: Option<usize>,
    #[arg(long)]
    seed: Option<u64>,
    /// Seed of the validation hold-out alone (default: --seed).
    #[arg(long)]
    val_seed: Option<u64>,
    /// Simulated windows: choose checkpoints on the validation board (VAL) scanned by these sensor
    /// builds instead of on the hold-out of the training windows: `validation` (builds 51 and 52,
    /// neither trained nor tested on) or `training` [default: the hold-out].
    #[arg(long, value_enum)]
    val_builds: Option<crate::common::SensorBuilds>,
    /// Simulated windows: the sensor builds the training scans are made with, numbers and ranges
    /// (`1-24`), trial t by the (t mod n)-th; never 51-60 (validation) or 101-102 (test)
    /// [default: the training builds 1-4].
    #[arg(long)]
    train_builds: Option<String>,
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

/// The recipe named by `--recipe` (or `base`), with every given flag written over it.
fn recipe(a: &Args, base: Option<SnnRecipe>) -> Result<SnnRecipe> {
    let mut r = match (&a.recipe, base) {
        (Some(name), _) => SnnRecipe::load(name)?,
        (None, Some(b)) => b,
        (None, None) => SnnRecipe::default(),
    };
    macro_rules! set {
        ($($field:ident <- $flag:expr),* $(,)?) => { $( if let Some(v) = $flag.clone() { r.$field = v; } )* };
    }
    set!(task <- a.task, jitter_ms <- a.jitter_ms, blank_cells <- a.blank_cells, realism <- a.realism, trials <- a.trials, word_rows <- a.words, letter_rows <- a.letter_rows, pair_rows <- a.pair_rows, train_speeds_mm_s <- a.train_speeds, train_depths_mm <- a.train_depths, pool <- a.pool,
        center <- a.center, period_us <- a.period_us, sigma_delta <- a.sigma_delta, dt_us <- a.dt_us,
        hidden <- a.hidden, neuron <- a.neuron, tau_mem_us <- a.tau_mem_us, tau_syn_us <- a.tau_syn_us,
        tau_out_us <- a.tau_out_us, reset <- a.reset, clip_norm <- a.clip_norm, warmup_steps <- a.warmup_steps, readout <- a.readout,
        readout_gradient <- a.readout_gradient, surrogate <- a.surrogate, surrogate_scale <- a.surrogate_scale,
        init_gain <- a.init_gain, epochs <- a.epochs, drop_events <- a.drop_events, stretch <- a.stretch,
        event_jitter_us <- a.event_jitter_us, weight_decay <- a.weight_decay, anchor_decay <- a.anchor_decay, loss_spike_guard <- a.loss_spike_guard,
        frozen_layers <- a.freeze_layers, average_epochs <- a.average_epochs,
        dropout <- a.dropout, class_balance <- a.class_balance, batch_size <- a.batch_size, lr <- a.lr, val_fraction <- a.val_fraction,
        patience <- a.patience, seed <- a.seed, trainer <- a.trainer, gradient_cutoff <- a.gradient_cutoff,
        chip_quantisation <- a.chip_quantisation);
    if a.chip.is_some() {
        r.chip = a.chip;
    }
    // refused before any window is simulated (the trainers refuse it too)
    learn::train::check_class_balance(r.class_balance).context("--class-balance")?;
    learn::train::check_loss_spike_guard(r.loss_spike_guard).context("--loss-spike-guard")?;
    // the library's rule (within the labeler's grid, first below last), checked here already
    if let Some(rows) = &a.crop_rows {
        r.crop_rows = Some(crate::common::pooled_rows("--crop-rows", rows)?);
    }
    if let Some(rows) = &a.band_rows {
        r.band_rows = Some(crate::common::pooled_rows("--band-rows", rows)?);
    }
    match a.braille {
        Some(pipeline::code::BrailleCode::Grade1Letters) => {
            r.cells = None;
            if r.task == Task::Cells {
                r.task = Task::Chars;
            }
        }
        Some(code) => {
            r.cells = Some(code);
            if r.task == Task::Chars {
                r.task = Task::Cells;
            }
        }
        None => {}
    }
    r.check_truncation |= a.check_truncation;
    r.interpolate |= a.interpolate;
    r.bias |= a.bias;
    r.recurrent |= a.recurrent;
    if a.recurrent_init_gain.is_some() {
        r.recurrent_init_gain = a.recurrent_init_gain;
    }
    if a.val_seed.is_some() {
        r.val_seed = a.val_seed;
    }
    if let Some(builds) = &a.train_builds {
        let builds = corpus::world::parse_builds(builds).context("--train-builds")?;
        // the library's rule (no validation or test build), checked before any window is made
        corpus::World::train_on(r.realism, &builds).context("--train-builds")?;
        r.train_builds = Some(builds);
    }
    if a.val_builds.is_some() {
        r.val_builds = a.val_builds;
    }
    Ok(r)
}

pub fn run(args: Args) -> Result<()> {
    // a dataset folder: its profile, and the recipe derived from it when none is named
    let dataset = match (&args.data, args.arch) {
        (Some(d), Arch::Snn) => {
            let named = args.recipe.as_deref().map(SnnRecipe::load).transpose()?;
            let period = args.period_us.or(named.map(|r| r.period_us)).unwrap_or(SnnRecipe::default().period_us);
            Some(Dataset::load(d, period)?)
        }
        _ => None,
    };
    let profile = dataset.as_ref().map(DataProfile::of).transpose()?;
    let r = recipe(&args, profile.as_ref().map(derived_recipe))?;
    if args.print_recipe {
        if let Some(p) = &profile {
            eprintln!("{p}");
        }
        println!("{}", serde_json::to_string_pretty(&r)?);
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
    if args.search || args.collect.is_some() {
        let (Some(dataset), Some(profile)) = (&dataset, &profile) else {
            bail!("--search and --collect need --data (a tactile dataset folder) and the SNN");
        };
        return search(&args, dataset, profile, &r, &out);
    }
    if out.exists() && !args.force {
        bail!("{}: exists; pass --force to replace it", out.display());
    }
    if !args.distill_from.is_empty() && args.arch != Arch::Snn {
        bail!("--distill-from trains an SNN (--arch snn)");
    }
    let eval_test = if args.eval_test { EvalTest::Yes } else { EvalTest::No };
    let mut epochs = Epochs::new(args.quiet);
    let bar = Bar::default();
    let trained = match (args.arch, &args.data) {
        (Arch::Resnet, Some(_)) => bail!("the ResNet trains on simulated character windows; --data is for the SNN"),
        (Arch::Resnet, None) => {
            if args.trainer.is_some() || args.gradient_cutoff.is_some() {
                bail!("--trainer and --gradient-cutoff choose how an SNN is trained; the ResNet trains on burn");
            }
            if args.train_builds.is_some() {
                bail!("--train-builds: the ResNet trains on the training builds (1-4)");
            }
            let t = ResnetTraining {
                preset: args.preset,
                preprocess: args.aug,
                task: r.task,
                jitter_ms: r.jitter_ms,
                blank_cells: r.blank_cells,
                pool: args.pool.unwrap_or(1),
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
            experiments::train::fit::train_windows(&r, rec.as_ref(), args.init.as_deref(), &mut epochs, &bar)?
        }
        (Arch::Snn, Some(_)) => {
            if args.crop_rows.is_some() || args.band_rows.is_some() {
                bail!(
                    "--crop-rows and --band-rows crop simulated windows; a dataset folder's taxels are the input as they are"
                );
            }
            if args.train_builds.is_some() {
                bail!("--train-builds chooses the sensors of simulated scans; a dataset folder is recorded data");
            }
            let dataset = dataset.as_ref().expect("loaded above for the SNN");
            if args.recipe.is_none()
                && let Some(p) = &profile
            {
                eprintln!("{p}; the recipe derived from it (--print-recipe shows it)");
            }
            let distill = (!args.distill_from.is_empty()).then(|| experiments::train::fit::DistillFrom {
                paths: args.distill_from.clone(),
                distill: learn::sparse::Distill { weight: args.distill_weight, temperature: args.distill_temperature },
            });
            let data = TactileData::encode(dataset, &r)?;
            train_on(&r, &data, eval_test, args.init.as_deref(), distill.as_ref(), &mut epochs)?
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
fn search(args: &Args, dataset: &Dataset, profile: &DataProfile, base: &SnnRecipe, out: &Path) -> Result<()> {
    if let Some(m) = args.budget_min
        && !(m.is_finite() && m >= 0.0)
    {
        bail!("--budget-min: expected a number of minutes, 0 or more, got {m}");
    }
    let dir = args.collect.clone().or_else(|| args.search_dir.clone()).unwrap_or_else(|| out.with_extension("search"));
    // the fixed rule's second search (--both-gradients)
    let exact = SnnRecipe { gradient_cutoff: 0.0, ..base.clone() };
    let run = |base, dir| SearchRun {
        dataset,
        profile,
        base,
        space: SearchSpace {
            trials: args.search_trials,
            epochs: args.search_epochs,
            trial_seeds: args.trial_seeds.max(1),
            halving: args.search_halving.then_some(Halving::DEFAULT),
            step_scale: match (&args.search_step_scale[..], args.both_gradients) {
                ([], true) => experiments::train::search::RULE_STEP_SCALE.to_vec(),
                ([], false) => SearchSpace::default().step_scale,
                (given, _) => given.to_vec(),
            },
            ..SearchSpace::default()
        },
        dir,
        shard: Shard::ALL,
        run_trials: args.search,
        budget: args.budget_min.map(|m| std::time::Duration::from_secs_f64(60.0 * m)),
        seeds: args.seeds,
        eval_test: if args.eval_test { EvalTest::Yes } else { EvalTest::No },
        out: out.to_path_buf(),
        force: args.force,
    };
    if args.both_gradients {
        if base.trainer != TrainerChoice::Sparse || base.gradient_cutoff <= 0.0 {
            bail!(
                "--both-gradients: its first search is the sparse trainer's truncated one, but this recipe has the {:?} trainer with gradient cutoff {}",
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
