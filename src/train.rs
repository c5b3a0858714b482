//! `braille train`: trains a classifier and saves it as a model file. The SNN starts from a
//! recipe (`--recipe NAME|FILE.json`, `experiments::recipe`) whose fields the flags override.

use crate::common::{Bar, Epochs};
use anyhow::{Result, bail};
use experiments::chars::{ResnetPreset, ResnetTraining};
use experiments::datasets::Task;
use experiments::recipe::{NeuronChoice, ReadoutGradient, SnnRecipe, SurrogateChoice};
use pipeline::augment::Preprocess;
use snn::model_file::{Arch, Readout};
use snn::neuron::Reset;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[arg(long, value_enum, default_value = "snn")]
    arch: Arch,
    /// A dataset folder in the iCub Braille layout (events: samples.csv, events.csv, split.csv;
    /// analog: raw.csv, split.csv). Without it, both architectures train on simulated windows.
    #[arg(long)]
    data: Option<PathBuf>,
    /// The SNN's recipe: a preset (default, raw1350, th10, chars, words, segment) or a JSON file of
    /// one (missing fields take the defaults); the flags below override its fields.
    #[arg(long, default_value = "default")]
    recipe: String,
    /// Print the recipe the flags make, as JSON, and stop.
    #[arg(long)]
    print_recipe: bool,
    /// Without --data: what to learn from the simulated windows.
    #[arg(long, value_enum)]
    task: Option<Task>,
    /// Without --data, character windows: also each window shifted by this many ms either way
    /// (at 8 mm/s), as a streaming reader meets them (0: the paper's aligned windows only).
    #[arg(long)]
    jitter_ms: Option<f64>,
    /// Without --data: the simulator's nuisances (training sensor builds beyond `clean`)
    /// [recipe: clean].
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
    /// Simulated windows: sum-pooling of the 64x80 crop [default: the recipe's (2) for the SNN, 1
    /// for the ResNet].
    #[arg(long)]
    pool: Option<usize>,
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
    /// Stochastic weight averaging over the last this many epochs (0: off).
    #[arg(long)]
    average_epochs: Option<usize>,
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
    /// Model file to write.
    #[arg(long, required_unless_present = "print_recipe")]
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

/// The recipe named by `--recipe`, with every given flag written over it.
fn recipe(a: &Args) -> Result<SnnRecipe> {
    let mut r = SnnRecipe::load(&a.recipe)?;
    macro_rules! set {
        ($($field:ident <- $flag:expr),* $(,)?) => { $( if let Some(v) = $flag.clone() { r.$field = v; } )* };
    }
    set!(task <- a.task, jitter_ms <- a.jitter_ms, realism <- a.realism, trials <- a.trials, word_rows <- a.words, pool <- a.pool,
        center <- a.center, period_us <- a.period_us, sigma_delta <- a.sigma_delta, dt_us <- a.dt_us,
        hidden <- a.hidden, neuron <- a.neuron, tau_mem_us <- a.tau_mem_us, tau_syn_us <- a.tau_syn_us,
        tau_out_us <- a.tau_out_us, reset <- a.reset, clip_norm <- a.clip_norm, readout <- a.readout,
        readout_gradient <- a.readout_gradient, surrogate <- a.surrogate, surrogate_scale <- a.surrogate_scale,
        init_gain <- a.init_gain, epochs <- a.epochs, drop_events <- a.drop_events, stretch <- a.stretch,
        event_jitter_us <- a.event_jitter_us, weight_decay <- a.weight_decay, average_epochs <- a.average_epochs,
        dropout <- a.dropout, batch_size <- a.batch_size, lr <- a.lr, val_fraction <- a.val_fraction,
        patience <- a.patience, seed <- a.seed);
    r.interpolate |= a.interpolate;
    r.bias |= a.bias;
    r.recurrent |= a.recurrent;
    if a.recurrent_init_gain.is_some() {
        r.recurrent_init_gain = a.recurrent_init_gain;
    }
    if a.val_seed.is_some() {
        r.val_seed = a.val_seed;
    }
    Ok(r)
}

pub fn run(args: Args) -> Result<()> {
    let r = recipe(&args)?;
    if args.print_recipe {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    let out = args.out.clone().expect("clap requires --out");
    if out.exists() && !args.force {
        bail!("{}: exists; pass --force to replace it", out.display());
    }
    let mut epochs = Epochs::new(args.quiet);
    let bar = Bar::default();
    let trained = match (args.arch, &args.data) {
        (Arch::Resnet, Some(_)) => bail!("the ResNet trains on simulated character windows; --data is for the SNN"),
        (Arch::Resnet, None) => {
            let t = ResnetTraining {
                preset: args.preset,
                preprocess: args.aug,
                task: r.task,
                jitter_ms: r.jitter_ms,
                pool: args.pool.unwrap_or(1),
                trials: r.trials,
                word_rows: r.word_rows,
                realism: r.realism,
                train: r.train_config(),
            };
            let m = experiments::chars::train_resnet(&t, &mut epochs, &bar)?;
            eprintln!(
                "SIMULATED training windows ({} realism): SAB and UN at 8 mm/s, 1.5 mm, {} rows of random words: {} scans ({} skipped: window count off), {} training and {} validation windows of {:?}",
                t.realism,
                t.word_rows,
                m.scans,
                m.skipped_scans,
                m.train_windows,
                m.val_windows,
                m.model.input.shape()
            );
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            m.model.save(&out, args.force)?;
            if let Some(h) = &args.history {
                experiments::write_json(h, &m.history, args.force)?;
            }
            eprintln!(
                "best validation accuracy {:.2}% (SIMULATED); wrote {}",
                100.0 * m.best_val_accuracy,
                out.display()
            );
            return Ok(());
        }
        (Arch::Snn, None) => experiments::train::train_windows(&r, &mut epochs, &bar)?,
        (Arch::Snn, Some(d)) => experiments::train::train_tactile(&r, d, &mut epochs)?,
    };
    let d = &trained.data;
    eprintln!(
        "{}: {} classes, {} inputs, {} steps of {} us; train {} / validation {}{} samples, {:.1} input events per sample{}",
        d.data,
        d.classes,
        d.inputs,
        d.steps,
        d.dt_us,
        d.train,
        d.validation,
        d.test.map_or(String::new(), |t| format!(" / test {t}")),
        d.input_events_per_sample,
        d.scans.map_or(String::new(), |s| format!(
            "; {s} scans ({} skipped: window count off)",
            d.skipped_scans.unwrap_or(0)
        ))
    );
    if let Some((accuracy, chosen)) = trained.average {
        let verdict = if chosen { "chosen" } else { "not chosen" };
        eprintln!(
            "weights averaged over the last {} epochs: validation {:.1}%, {verdict}",
            r.average_epochs,
            100.0 * accuracy
        );
    }
    let kept = if d.validation == 0 {
        format!("kept epoch {} (no validation set)", trained.best_epoch)
    } else {
        format!("best epoch {} (validation {:.1}%)", trained.best_epoch, 100.0 * trained.best_val_accuracy)
    };
    if d.test.is_some() {
        eprintln!(
            "{kept}; test accuracy on the event-driven engine: {:.2}% of {}",
            100.0 * trained.engine_accuracy,
            trained.engine_n
        );
    } else {
        eprintln!(
            "{kept}: {:.1}% of the validation windows on the event-driven engine (SIMULATED)",
            100.0 * trained.engine_accuracy
        );
    }
    experiments::train::save_model(&trained.model, &out, args.force)?;
    if let Some(h) = &args.history {
        experiments::write_json(h, &trained.history, args.force)?;
    }
    eprintln!("wrote {} (peak RSS {:.0} MB)", out.display(), experiments::peak_rss_mb().unwrap_or(f64::NAN));
    Ok(())
}
