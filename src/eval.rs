//! `braille eval`: a trained model's accuracy on a dataset folder's split, run by the
//! event-driven engine.

use anyhow::{Context, Result};
use encoders::dataset::{Dataset, Split};
use learn::data::{SpikeSet, TactileEncoding};
use rayon::prelude::*;
use serde::Serialize;
use snn::engine::{Engine, Mode};
use snn::model_file::{Readout, SnnConfig, SnnModel};
use snn::network::Network;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SplitArg {
    Train,
    /// The validation hold-out of the train split that `braille train` kept with the same
    /// `--val-fraction` and `--val-seed`.
    Validation,
    Test,
    All,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    Stepped,
    Async,
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct Args {
    #[command(subcommand)]
    what: Option<What>,
    /// A dataset folder in the iCub Braille layout.
    #[arg(long, required = true)]
    data: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "test")]
    split: SplitArg,
    /// `--split validation`: the share of the train split held out (as `braille train --val-fraction`).
    #[arg(long, default_value_t = 0.1)]
    val_fraction: f64,
    /// `--split validation`: the hold-out's seed (as `braille train --val-seed`, by default its `--seed`).
    #[arg(long, default_value_t = 1)]
    val_seed: u64,
    /// The model file.
    #[arg(long, required = true)]
    model: Option<PathBuf>,
    /// Engine mode: `stepped` reproduces the trained network exactly; `async` fires at threshold
    /// crossings (LIF and IF layers only).
    #[arg(long, value_enum, default_value = "stepped")]
    mode: ModeArg,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// Also write each sample's truth, prediction and readout (CSV: the split's samples in file
    /// order), for confusion analysis or combining models.
    #[arg(long)]
    predictions: Option<PathBuf>,
}

#[derive(clap::Subcommand)]
pub enum What {
    /// A character classifier on simulated scans of a board (SIMULATED data).
    Chars(crate::chars::EvalCharsArgs),
    /// Word reading on simulated scans of a board: the paper's four conditional metrics (SIMULATED data).
    Words(crate::words::EvalWordsArgs),
}

/// Accuracy and work of an SNN on a set of spike trains.
#[derive(Debug, Clone, Serialize)]
pub struct Scored {
    pub accuracy: f64,
    pub n: usize,
    pub correct: usize,
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    pub input_events_per_sample: f64,
    /// `[truth][predicted]` counts.
    pub confusion: Vec<Vec<u32>>,
    /// Per sample: the predicted class and the readout it was taken from (max membranes or
    /// spike counts).
    #[serde(skip)]
    pub predictions: Vec<(usize, Vec<f32>)>,
}

/// Runs every sample through the event-driven engine (stepped mode) and scores the readout.
pub fn snn_accuracy(network: &Network, config: &SnnConfig, set: &SpikeSet) -> Result<Scored> {
    snn_accuracy_in(network, config, set, Mode::Stepped)
}

pub fn snn_accuracy_in(network: &Network, config: &SnnConfig, set: &SpikeSet, mode: Mode) -> Result<Scored> {
    let engine = Engine::new(network, config.dt_us, mode)?;
    let n_out = engine.n_outputs();
    let results: Vec<(Vec<f32>, u64, u64, u64)> = set
        .trains
        .par_iter()
        .map_init(
            || engine.state(0),
            |st, train| -> Result<(Vec<f32>, u64, u64, u64)> {
                engine.run_train(st, train)?;
                let readout = match config.readout {
                    Readout::MaxMembrane => st.output_v_max().to_vec(),
                    Readout::SpikeCount => st.output_counts(n_out).into_iter().map(|c| c as f32).collect(),
                };
                Ok((readout, st.stats.synops, st.stats.spikes.iter().sum(), st.stats.input_events))
            },
        )
        .collect::<Result<_>>()?;
    let k = set.classes.len().max(n_out);
    let mut confusion = vec![vec![0u32; k]; k];
    let mut correct = 0;
    let (mut synops, mut spikes) = (0u64, 0u64);
    // sensor events (a step's several events at one input reach the engine as one weighted input)
    let inputs: u64 = set.trains.iter().map(|t| t.total()).sum();
    let mut predictions = Vec::with_capacity(results.len());
    for ((readout, s, z, _), &label) in results.into_iter().zip(&set.labels) {
        let pred = argmax(readout.iter().copied());
        confusion[label][pred] += 1;
        correct += usize::from(pred == label);
        synops += s;
        spikes += z;
        predictions.push((pred, readout));
    }
    let n = set.len().max(1) as f64;
    Ok(Scored {
        accuracy: correct as f64 / n,
        n: set.len(),
        correct,
        synops_per_sample: synops as f64 / n,
        spikes_per_sample: spikes as f64 / n,
        input_events_per_sample: inputs as f64 / n,
        confusion,
        predictions,
    })
}

/// The index of the largest value; the first on ties (as burn's argmax).
pub fn argmax(v: impl Iterator<Item = f32>) -> usize {
    let mut best = (0, f32::NEG_INFINITY);
    for (i, x) in v.enumerate() {
        if x > best.1 {
            best = (i, x);
        }
    }
    best.0
}

#[derive(Serialize)]
struct Report<'a> {
    data: String,
    split: &'a str,
    model: String,
    mode: &'a str,
    accuracy: f64,
    n: usize,
    correct: usize,
    synops_per_sample: f64,
    spikes_per_sample: f64,
    input_events_per_sample: f64,
}

pub fn run(args: Args) -> Result<()> {
    match args.what {
        Some(What::Chars(a)) => return crate::chars::eval(a),
        Some(What::Words(a)) => return crate::words::eval(a),
        None => {}
    }
    let (Some(data_dir), Some(model_path)) = (args.data.clone(), args.model.clone()) else {
        anyhow::bail!("eval needs --data DIR and --model PATH, or the `chars` or `words` subcommand");
    };
    let model = SnnModel::load(&model_path)?;
    let encoding: TactileEncoding = serde_json::from_value(model.preprocess.clone())
        .with_context(|| format!("{}: header `preprocess` is not a tactile encoding", model_path.display()))?;
    let data = Dataset::load(&data_dir, encoding.period_us)?;
    let split = match args.split {
        SplitArg::Train | SplitArg::Validation => Some(Split::Train),
        SplitArg::Test => Some(Split::Test),
        SplitArg::All => None,
    };
    let mut set = encoding.encode(&data, split)?;
    if args.split == SplitArg::Validation {
        anyhow::ensure!(
            args.val_fraction > 0.0 && args.val_fraction < 1.0,
            "--val-fraction must lie between 0 and 1, got {}",
            args.val_fraction
        );
        set = set.stratified_split(args.val_fraction, args.val_seed).1;
    }
    let mode = match args.mode {
        ModeArg::Stepped => Mode::Stepped,
        ModeArg::Async => Mode::Async,
    };
    let s = snn_accuracy_in(&model.network, &model.config, &set, mode)?;
    let report = Report {
        data: data_dir.display().to_string(),
        split: match args.split {
            SplitArg::Train => "train",
            SplitArg::Validation => "validation",
            SplitArg::Test => "test",
            SplitArg::All => "all",
        },
        model: model_path.display().to_string(),
        mode: match mode {
            Mode::Stepped => "stepped",
            Mode::Async => "async",
        },
        accuracy: s.accuracy,
        n: s.n,
        correct: s.correct,
        synops_per_sample: s.synops_per_sample,
        spikes_per_sample: s.spikes_per_sample,
        input_events_per_sample: s.input_events_per_sample,
    };
    if let Some(path) = &args.predictions {
        write_predictions(path, &model.classes, &set.labels, &s.predictions)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} ({} split, {} samples): accuracy {:.2}% ({} engine); {:.0} synops, {:.0} spikes, {:.1} input events per sample",
            report.data,
            report.split,
            report.n,
            100.0 * report.accuracy,
            report.mode,
            report.synops_per_sample,
            report.spikes_per_sample,
            report.input_events_per_sample
        );
    }
    Ok(())
}

/// Per sample: `index,truth,predicted,` and one readout column per class.
fn write_predictions(
    path: &Path,
    classes: &[String],
    labels: &[usize],
    predictions: &[(usize, Vec<f32>)],
) -> Result<()> {
    use std::fmt::Write as _;
    // a class name with a comma, quote or line break is quoted (RFC 4180)
    let field = |s: &str| {
        if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
    };
    let mut out = String::from("index,truth,predicted");
    for c in classes {
        write!(out, ",{}", field(&format!("readout_{c}")))?;
    }
    out.push('\n');
    for (k, (&label, (pred, readout))) in labels.iter().zip(predictions).enumerate() {
        write!(out, "{k},{},{}", field(&classes[label]), field(&classes[*pred]))?;
        for v in readout {
            write!(out, ",{v}")?;
        }
        out.push('\n');
    }
    std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))
}
