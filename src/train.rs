//! `braille train`: trains a classifier and saves it as a model file.

use anyhow::{Context, Result, bail};
use encoders::dataset::{Dataset, Split};
use encoders::sigma_delta::SigmaDeltaConfig;
use indicatif::{ProgressBar, ProgressStyle};
use learn::data::{SpikeSet, TactileEncoding};
use learn::snn::SnnTwin;
use learn::train::{EpochReport, Observer, TrainConfig};
use snn::model_file::{Readout, SnnConfig, SnnModel};
use snn::neuron::{Discretisation, LifConfig, NeuronKind, Reset, Surrogate};
use snn::spec::{LayerSpec, NetworkSpec, OpSpec};
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ArchArg {
    Snn,
    Resnet,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TaskArg {
    /// The character classifier: 26 letters.
    Chars,
    /// The segmentation network: character present against background (the paper's negatives).
    Segment,
}

impl TaskArg {
    pub fn task(self) -> pipeline::chars::Task {
        match self {
            TaskArg::Chars => pipeline::chars::Task::Chars,
            TaskArg::Segment => pipeline::chars::Task::Segment,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum NeuronArg {
    Lif,
    CubaLif,
    If,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ResetArg {
    Zero,
    Subtract,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReadoutArg {
    MaxMembrane,
    SpikeCount,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReadoutGradientArg {
    StraightThrough,
    Clamped,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SurrogateArg {
    FastSigmoid,
    Arctan,
    Triangle,
}

#[derive(clap::Args)]
pub struct Args {
    #[arg(long, value_enum, default_value = "snn")]
    arch: ArchArg,
    /// A dataset folder in the iCub Braille layout (events: samples.csv, events.csv, split.csv;
    /// analog: raw.csv, split.csv). Required for the SNN; the ResNet trains on simulated scans.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Without --data: what to learn from the simulated windows.
    #[arg(long, value_enum, default_value = "chars")]
    task: TaskArg,
    /// Without --data, character windows: also each window shifted by this many ms either way
    /// (at 8 mm/s), as a streaming reader meets them (0: the paper's aligned windows only).
    #[arg(long, default_value_t = 0.0)]
    jitter_ms: f64,
    /// ResNet: the network's size.
    #[arg(long, value_enum, default_value = "lite")]
    preset: crate::chars::PresetArg,
    /// ResNet: the paper's input configuration.
    #[arg(long, value_enum, default_value = "normaug")]
    aug: crate::chars::AugArg,
    /// Without --data: simulated scans per board row (SAB and UN, 8 mm/s, 1.5 mm).
    #[arg(long, default_value_t = 10)]
    trials: u64,
    /// Without --data: rows of random words (TextBlob's frequent words, none of the EV board's)
    /// added to the training boards, so that letters are also seen with neighbours as in words
    /// (0: the paper's protocol, SAB and UN only).
    #[arg(long, default_value_t = 0)]
    words: usize,
    /// Simulated windows: sum-pooling of the 64x80 crop (2: 32x40 per polarity) [default: 2 for
    /// the SNN, 1 for the ResNet].
    #[arg(long)]
    pool: Option<usize>,
    /// SNN on simulated windows: centre each window vertically (a whole-row shift of its events).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    center: bool,
    /// Sampling period of analog data, in microseconds (the iCub taxels: 40 Hz).
    #[arg(long, default_value_t = 25_000)]
    period_us: i64,
    /// Sigma-delta threshold for analog data, in the signal's units.
    #[arg(long, default_value_t = 2.0)]
    sigma_delta: f32,
    /// Place sigma-delta events at the interpolated crossing time.
    #[arg(long)]
    interpolate: bool,
    /// Simulation step, in microseconds.
    #[arg(long, default_value_t = 10_000)]
    dt_us: i64,
    /// Hidden layer sizes, comma separated.
    #[arg(long, default_value = "256", value_delimiter = ',')]
    hidden: Vec<usize>,
    #[arg(long, value_enum, default_value = "cuba-lif")]
    neuron: NeuronArg,
    /// Membrane time constant of hidden neurons, in microseconds.
    #[arg(long, default_value_t = 500_000.0)]
    tau_mem_us: f64,
    /// Synaptic time constant (CubaLIF), in microseconds.
    #[arg(long, default_value_t = 200_000.0)]
    tau_syn_us: f64,
    /// Membrane time constant of the leaky-integrator readout, in microseconds.
    #[arg(long, default_value_t = 200_000.0)]
    tau_out_us: f64,
    /// Biases in the hidden layers (a bias current also gives neurons a sense of time since the
    /// sample's start; neuromorphic chips often prefer networks without).
    #[arg(long)]
    bias: bool,
    /// How hidden neurons reset after a spike. NIR (and so the chips) can only express
    /// `zero` (to v_reset); `subtract` keeps the excess.
    #[arg(long, value_enum, default_value = "subtract")]
    reset: ResetArg,
    /// Clip the gradient norm to this (0: off).
    #[arg(long, default_value_t = 0.0)]
    clip_norm: f64,
    /// Recurrent connections in the hidden layers.
    #[arg(long)]
    recurrent: bool,
    #[arg(long, value_enum, default_value = "max-membrane")]
    readout: ReadoutArg,
    /// Max-membrane readout: how the clamp of the readout at zero backpropagates. `straight-through`
    /// (the default) lets a readout whose membrane stays below zero keep learning; `clamped` gives
    /// it no gradient (such a class can stop being predicted for good).
    #[arg(long, value_enum, default_value = "straight-through")]
    readout_gradient: ReadoutGradientArg,
    #[arg(long, value_enum, default_value = "fast-sigmoid")]
    surrogate: SurrogateArg,
    /// Surrogate sharpness: fast-sigmoid slope, arctan alpha or triangle width.
    #[arg(long, default_value_t = 10.0)]
    surrogate_scale: f32,
    /// Weight scale at initialisation (times PyTorch's 1/sqrt(fan_in)).
    #[arg(long, default_value_t = 1.0)]
    init_gain: f32,
    /// With --recurrent: the recurrent weights' scale at initialisation (default: --init-gain; 0
    /// starts the network feed-forward and lets training grow the recurrence).
    #[arg(long)]
    recurrent_init_gain: Option<f32>,
    #[arg(long, default_value_t = 60)]
    epochs: usize,
    /// Augmentation: probability of dropping each input event in training.
    #[arg(long, default_value_t = 0.0)]
    drop_events: f64,
    /// Augmentation: time stretched by a factor in 1 +- this, per training sample.
    #[arg(long, default_value_t = 0.0)]
    stretch: f64,
    /// Augmentation: each input event moved by a whole number of steps drawn uniformly within
    /// +- this many microseconds (0: off).
    #[arg(long, default_value_t = 0)]
    event_jitter_us: i64,
    /// Decoupled weight decay (AdamW), per unit of learning rate (0: plain Adam).
    #[arg(long, default_value_t = 0.0)]
    weight_decay: f64,
    /// Stochastic weight averaging: the mean weights of the last this many epochs compete with
    /// each epoch's on validation (0: off).
    #[arg(long, default_value_t = 0)]
    average_epochs: usize,
    /// Neuron dropout in training: each hidden spiking neuron silenced with this probability for
    /// a whole sample (0: off).
    #[arg(long, default_value_t = 0.0)]
    dropout: f64,
    #[arg(long, default_value_t = 32)]
    batch_size: usize,
    #[arg(long, default_value_t = 2e-3)]
    lr: f64,
    /// Share of the training split held out for validation (best checkpoint, early stopping).
    #[arg(long, default_value_t = 0.1)]
    val_fraction: f64,
    /// Stop after this many epochs without a better validation accuracy (0: never).
    #[arg(long, default_value_t = 0)]
    patience: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seed of the validation hold-out alone (default: --seed), so that models trained with other
    /// seeds are compared, or their predictions combined, on one hold-out none of them trained on.
    #[arg(long)]
    val_seed: Option<u64>,
    /// Model file to write.
    #[arg(long)]
    out: PathBuf,
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

/// Progress bars: one per epoch, with running loss and accuracy, and a line per finished epoch.
struct Bars {
    bar: Option<ProgressBar>,
    quiet: bool,
    sum: (f64, f64, usize),
}

impl Observer for Bars {
    fn epoch_begin(&mut self, epoch: usize, batches: usize) {
        self.sum = (0.0, 0.0, 0);
        if !self.quiet {
            let bar = ProgressBar::new(batches as u64);
            bar.set_style(
                ProgressStyle::with_template("epoch {prefix:>3} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
                    .expect("a valid template")
                    .progress_chars("=> "),
            );
            bar.set_prefix(epoch.to_string());
            self.bar = Some(bar);
        }
    }

    fn batch(&mut self, loss: f64, accuracy: f64) {
        self.sum = (self.sum.0 + loss, self.sum.1 + accuracy, self.sum.2 + 1);
        if let Some(b) = &self.bar {
            let n = self.sum.2 as f64;
            b.set_message(format!("loss {:.3} acc {:.1}%", self.sum.0 / n, 100.0 * self.sum.1 / n));
            b.inc(1);
        }
    }

    fn epoch_end(&mut self, r: &EpochReport) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
        {
            eprintln!(
                "epoch {:>3}: lr {:.2e} train loss {:.3} acc {:5.1}% | val loss {:.3} acc {:5.1}% | spikes/sample {:?} | {:.1} s",
                r.epoch,
                r.lr,
                r.train_loss,
                100.0 * r.train_accuracy,
                r.val_loss,
                100.0 * r.val_accuracy,
                r.val_spikes_per_sample.iter().map(|s| s.round() as i64).collect::<Vec<_>>(),
                r.seconds
            );
        }
    }
}

/// The network for `n_inputs` inputs and `n_classes` classes.
fn network_spec(args: &Args, n_inputs: usize, n_classes: usize) -> Result<NetworkSpec> {
    let dt = args.dt_us as f64;
    let hidden = match args.neuron {
        NeuronArg::Lif => LifConfig::lif(args.tau_mem_us),
        NeuronArg::CubaLif => LifConfig::cuba_lif(args.tau_mem_us, args.tau_syn_us),
        NeuronArg::If => LifConfig::integrate_and_fire(),
    }
    .with_reset(match args.reset {
        ResetArg::Zero => Reset::Zero,
        ResetArg::Subtract => Reset::Subtract,
    })
    .discretise(dt, Discretisation::Exact);
    if args.hidden.is_empty() || args.hidden.contains(&0) {
        bail!("--hidden needs positive layer sizes");
    }
    if args.recurrent_init_gain.is_some() && !args.recurrent {
        bail!("--recurrent-init-gain needs --recurrent");
    }
    let mut layers: Vec<LayerSpec> = args
        .hidden
        .iter()
        .map(|&n| LayerSpec {
            op: OpSpec::Dense { n_out: n },
            neurons: Some(hidden),
            recurrent: args.recurrent,
            bias: args.bias,
            recurrent_bias: false,
        })
        .collect();
    let out = match args.readout {
        ReadoutArg::MaxMembrane => {
            let mut p = LifConfig::lif(args.tau_out_us).discretise(dt, Discretisation::Exact);
            p.kind = NeuronKind::Li;
            p
        }
        ReadoutArg::SpikeCount => hidden,
    };
    layers.push(LayerSpec {
        op: OpSpec::Dense { n_out: n_classes },
        neurons: Some(out),
        recurrent: false,
        bias: false,
        recurrent_bias: false,
    });
    Ok(NetworkSpec { input_shape: vec![n_inputs], layers })
}

pub fn run(args: Args) -> Result<()> {
    if args.out.exists() && !args.force {
        bail!("{}: exists; pass --force to replace it", args.out.display());
    }
    let mut bars = Bars { bar: None, quiet: args.quiet, sum: (0.0, 0.0, 0) };
    let cfg = TrainConfig {
        epochs: args.epochs,
        batch_size: args.batch_size,
        lr: args.lr,
        seed: args.seed,
        patience: args.patience,
        augment: learn::train::Augment {
            drop_events: args.drop_events,
            stretch: args.stretch,
            event_jitter_us: args.event_jitter_us,
        },
        clip_norm: args.clip_norm,
        weight_decay: args.weight_decay,
        average_epochs: args.average_epochs,
        dropout: args.dropout,
        ..TrainConfig::default()
    };
    let data_dir = match (args.arch, &args.data) {
        (ArchArg::Resnet, Some(_)) => bail!("the ResNet trains on simulated character windows; --data is for the SNN"),
        (ArchArg::Resnet, None) => {
            return crate::chars::train(crate::chars::ResnetTrainArgs {
                preset: args.preset,
                aug: args.aug,
                task: args.task.task(),
                jitter_ms: args.jitter_ms,
                pool: args.pool.unwrap_or(1),
                trials: args.trials,
                word_rows: args.words,
                train: cfg,
                out: &args.out,
                force: args.force,
                history: args.history.as_ref(),
                observer: &mut bars,
            });
        }
        (ArchArg::Snn, None) => return train_snn_chars(&args, cfg, &mut bars),
        (ArchArg::Snn, Some(d)) => d.clone(),
    };
    let data = Dataset::load(&data_dir, args.period_us)?;
    let sd = SigmaDeltaConfig { threshold: args.sigma_delta, interpolate: args.interpolate };
    let encoding = TactileEncoding::fit(&data, sd, args.dt_us)?;
    let all_train = encoding.encode(&data, Some(Split::Train))?;
    let test = encoding.encode(&data, Some(Split::Test))?;
    let (train, val) = if args.val_fraction > 0.0 {
        all_train.stratified_split(args.val_fraction, args.val_seed.unwrap_or(args.seed))
    } else {
        (all_train.clone(), all_train.subset(&[]))
    };
    let events = |s: &SpikeSet| s.trains.iter().map(|t| t.total()).sum::<u64>() as f64 / s.len().max(1) as f64;
    eprintln!(
        "{}: {} classes, {} inputs, {} steps of {} us; train {} / validation {} / test {} samples, {:.1} input events per sample",
        data_dir.display(),
        data.classes.len(),
        encoding.n_inputs(),
        encoding.steps,
        encoding.dt_us,
        train.len(),
        val.len(),
        test.len(),
        events(&all_train)
    );
    let spec = network_spec(&args, encoding.n_inputs(), data.classes.len())?;
    let (outcome, network, config, surrogate, train_seconds) = fit(&args, spec, &train, &val, &cfg, &mut bars)?;
    let scored = crate::eval::snn_accuracy(&network, &config, &test)?;
    let kept = if val.is_empty() {
        format!("kept epoch {} (no validation set)", outcome.best_epoch)
    } else {
        format!("best epoch {} (validation {:.1}%)", outcome.best_epoch, 100.0 * outcome.best_val_accuracy)
    };
    eprintln!("{kept}; test accuracy on the event-driven engine: {:.2}% of {}", 100.0 * scored.accuracy, scored.n);
    let mut extra = serde_json::json!({
        "data": data_dir.file_name().map(|n| n.to_string_lossy().into_owned()),
        "test_accuracy": scored.accuracy,
    });
    if let Some(v) = args.val_seed {
        extra["val_seed"] = v.into();
    }
    let model = SnnModel {
        config,
        network,
        preprocess: serde_json::to_value(&encoding)?,
        classes: data.classes.clone(),
        provenance: provenance(&args, &cfg, surrogate, &outcome, train_seconds, extra),
    };
    save(&args, &model, &outcome.history)
}

/// The SNN on the CNN path's simulated character windows (SAB and UN, 8 mm/s, 1.5 mm, the same
/// scans and validation split as `--arch resnet` with the same trials and seed), the windows'
/// events fed as input spikes, one step per 10 ms frame.
fn train_snn_chars(args: &Args, cfg: TrainConfig, bars: &mut Bars) -> Result<()> {
    use crate::chars::{CharInput, LITE_COLS, LITE_ROWS, snn_set, training_windows};
    let pool = check_pool(args.pool.unwrap_or(2))?;
    let task = args.task.task();
    let input = CharInput {
        labeler: pipeline::labeling::LabelerConfig::default(),
        rows: LITE_ROWS,
        cols: LITE_COLS,
        pool,
        preprocess: if args.center { pipeline::augment::Preprocess::Norm } else { pipeline::augment::Preprocess::Raw },
        augment: pipeline::augment::AugmentConfig::default(),
    };
    let (all, train_idx, val_idx, n_scans, skipped) =
        training_windows(args.trials, args.seed, args.words, &input, task, args.jitter_ms)?;
    let train = snn_set(&input, &all, &train_idx, args.dt_us, task);
    let val = snn_set(&input, &all, &val_idx, args.dt_us, task);
    let events = |s: &SpikeSet| s.trains.iter().map(|t| t.total()).sum::<u64>() as f64 / s.len().max(1) as f64;
    eprintln!(
        "SIMULATED training windows: SAB and UN at 8 mm/s, 1.5 mm, {} rows of random words: {n_scans} scans ({skipped} skipped: window count off), {} training and {} validation windows; {} inputs, {} steps of {} us, {:.0} input events per window",
        args.words,
        train.len(),
        val.len(),
        train.n_inputs,
        train.steps,
        args.dt_us,
        events(&train)
    );
    let spec = network_spec(args, train.n_inputs, train.classes.len())?;
    let (outcome, network, config, surrogate, train_seconds) = fit(args, spec, &train, &val, &cfg, bars)?;
    let scored = crate::eval::snn_accuracy(&network, &config, &val)?;
    eprintln!(
        "{task:?}: best epoch {} (validation {:.1}% time-stepped, {:.1}% on the event-driven engine; SIMULATED)",
        outcome.best_epoch,
        100.0 * outcome.best_val_accuracy,
        100.0 * scored.accuracy
    );
    let model = SnnModel {
        config,
        network,
        preprocess: serde_json::to_value(&input)?,
        classes: task.classes(),
        provenance: provenance(
            args,
            &cfg,
            surrogate,
            &outcome,
            train_seconds,
            serde_json::json!({
                "data": "simulated (virtual Evetac): SAB and UN boards, 8 mm/s, 1.5 mm",
                "task": task,
                "jitter_ms": args.jitter_ms,
                "word_rows": args.words,
                "scans": n_scans,
                "train_windows": train.len(),
                "val_windows": val.len(),
            }),
        ),
    };
    save(args, &model, &outcome.history)
}

/// A pooling factor that divides the lite crop.
pub fn check_pool(pool: usize) -> Result<usize> {
    let (h, w) = (crate::chars::LITE_ROWS.len(), crate::chars::LITE_COLS.len());
    if pool == 0 || h % pool != 0 || w % pool != 0 {
        bail!("--pool must divide the {h}x{w} crop, got {pool}");
    }
    Ok(pool)
}

fn surrogate_and_readout(args: &Args) -> (Surrogate, Readout) {
    let surrogate = match args.surrogate {
        SurrogateArg::FastSigmoid => Surrogate::FastSigmoid { slope: args.surrogate_scale },
        SurrogateArg::Arctan => Surrogate::Arctan { alpha: args.surrogate_scale },
        SurrogateArg::Triangle => Surrogate::Triangle { width: args.surrogate_scale },
    };
    let readout = match args.readout {
        ReadoutArg::MaxMembrane => Readout::MaxMembrane,
        ReadoutArg::SpikeCount => Readout::SpikeCount,
    };
    (surrogate, readout)
}

/// Writes the model and, when asked, the training history.
fn save(args: &Args, model: &SnnModel, history: &[EpochReport]) -> Result<()> {
    save_model(model, &args.out, args.force)?;
    if let Some(h) = &args.history {
        crate::simulate::write_json(h, &history, args.force)?;
    }
    eprintln!("wrote {} (peak RSS {:.0} MB)", args.out.display(), crate::bench::peak_rss_mb().unwrap_or(f64::NAN));
    Ok(())
}

/// Writes an SNN model file, creating its folder; an existing file is kept unless `force`.
pub(crate) fn save_model(model: &SnnModel, out: &std::path::Path, force: bool) -> Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(model.save(out, force)?)
}

/// Trains `spec` from the seeded initialisation; the best checkpoint as an engine network.
fn fit(
    args: &Args,
    spec: NetworkSpec,
    train: &SpikeSet,
    val: &SpikeSet,
    cfg: &TrainConfig,
    observer: &mut dyn Observer,
) -> Result<(learn::train::Outcome, snn::network::Network, SnnConfig, Surrogate, f64)> {
    let (surrogate, readout) = surrogate_and_readout(args);
    let mut twin = SnnTwin::new(spec.clone(), surrogate, readout)?;
    twin.clamped_readout_gradient = args.readout_gradient == ReadoutGradientArg::Clamped;
    let init =
        spec.init_with_recurrent_gain(args.seed, args.init_gain, args.recurrent_init_gain.unwrap_or(args.init_gain))?;
    let started = std::time::Instant::now();
    let outcome = learn::train::train(&twin, &init, train, val, cfg, observer)?;
    let seconds = started.elapsed().as_secs_f64();
    if let Some((accuracy, chosen)) = outcome.average {
        let n = cfg.average_epochs.min(outcome.history.len());
        if val.is_empty() {
            eprintln!("weights averaged over the last {n} epochs: taken (no validation set)");
        } else {
            let verdict = if chosen { "chosen" } else { "not chosen" };
            eprintln!("weights averaged over the last {n} epochs: validation {:.1}%, {verdict}", 100.0 * accuracy);
        }
    }
    let network = spec.build(outcome.weights.clone())?;
    Ok((outcome, network, SnnConfig { network: spec, dt_us: args.dt_us, readout }, surrogate, seconds))
}

/// How a model was trained, with `extra` (an object) merged in.
fn provenance(
    args: &Args,
    cfg: &TrainConfig,
    surrogate: Surrogate,
    outcome: &learn::train::Outcome,
    seconds: f64,
    extra: serde_json::Value,
) -> serde_json::Value {
    let mut p = serde_json::json!({
        "train": cfg,
        "surrogate": format!("{surrogate:?}"),
        "readout_gradient": format!("{:?}", args.readout_gradient),
        "init_gain": args.init_gain,
        "recurrent_init_gain": args.recurrent_init_gain.unwrap_or(args.init_gain),
        "best_epoch": outcome.best_epoch,
        "val_accuracy": outcome.best_val_accuracy,
        "train_seconds": seconds,
        "peak_rss_mb": crate::bench::peak_rss_mb(),
    });
    if let (Some(p), serde_json::Value::Object(extra)) = (p.as_object_mut(), extra) {
        p.extend(extra);
    }
    p
}
