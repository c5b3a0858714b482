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
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SplitArg {
    Train,
    Test,
    All,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    Stepped,
    Async,
}

#[derive(clap::Args)]
pub struct Args {
    /// A dataset folder in the iCub Braille layout.
    #[arg(long)]
    data: PathBuf,
    #[arg(long, value_enum, default_value = "test")]
    split: SplitArg,
    /// The model file.
    #[arg(long)]
    model: PathBuf,
    /// Engine mode: `stepped` reproduces the trained network exactly; `async` fires at threshold
    /// crossings (LIF and IF layers only).
    #[arg(long, value_enum, default_value = "stepped")]
    mode: ModeArg,
    /// Print JSON.
    #[arg(long)]
    json: bool,
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
}

/// Runs every sample through the event-driven engine (stepped mode) and scores the readout.
pub fn snn_accuracy(network: &Network, config: &SnnConfig, set: &SpikeSet) -> Result<Scored> {
    snn_accuracy_in(network, config, set, Mode::Stepped)
}

pub fn snn_accuracy_in(network: &Network, config: &SnnConfig, set: &SpikeSet, mode: Mode) -> Result<Scored> {
    let engine = Engine::new(network, config.dt_us, mode)?;
    let n_out = engine.n_outputs();
    let results: Vec<(usize, u64, u64, u64)> = set
        .trains
        .par_iter()
        .map_init(
            || engine.state(0),
            |st, train| -> Result<(usize, u64, u64, u64)> {
                engine.run_train(st, train)?;
                let pred = match config.readout {
                    Readout::MaxMembrane => argmax(st.output_v_max().iter().copied()),
                    Readout::SpikeCount => argmax(st.output_counts(n_out).into_iter().map(|c| c as f32)),
                };
                Ok((pred, st.stats.synops, st.stats.spikes.iter().sum(), st.stats.input_events))
            },
        )
        .collect::<Result<_>>()?;
    let k = set.classes.len().max(n_out);
    let mut confusion = vec![vec![0u32; k]; k];
    let mut correct = 0;
    let (mut synops, mut spikes, mut inputs) = (0u64, 0u64, 0u64);
    for (&(pred, s, z, e), &label) in results.iter().zip(&set.labels) {
        confusion[label][pred] += 1;
        correct += usize::from(pred == label);
        synops += s;
        spikes += z;
        inputs += e;
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
    })
}

/// The index of the largest value; the first on ties (as burn's argmax).
fn argmax(v: impl Iterator<Item = f32>) -> usize {
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
    let model = SnnModel::load(&args.model)?;
    let encoding: TactileEncoding = serde_json::from_value(model.preprocess.clone())
        .with_context(|| format!("{}: header `preprocess` is not a tactile encoding", args.model.display()))?;
    let data = Dataset::load(&args.data, encoding.period_us)?;
    let split = match args.split {
        SplitArg::Train => Some(Split::Train),
        SplitArg::Test => Some(Split::Test),
        SplitArg::All => None,
    };
    let set = encoding.encode(&data, split)?;
    let mode = match args.mode {
        ModeArg::Stepped => Mode::Stepped,
        ModeArg::Async => Mode::Async,
    };
    let s = snn_accuracy_in(&model.network, &model.config, &set, mode)?;
    let report = Report {
        data: args.data.display().to_string(),
        split: match args.split {
            SplitArg::Train => "train",
            SplitArg::Test => "test",
            SplitArg::All => "all",
        },
        model: args.model.display().to_string(),
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
