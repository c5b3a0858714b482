//! Tactile datasets (folders in the iCub layout, real recordings): an SNN's accuracy and work on a
//! split, run by the event-driven engine (`braille eval --data`).

use crate::error::{Error, Result};
use crate::scoring::{Confusion, argmax};
use encoders::dataset::{Dataset, Split};
use learn::data::{SpikeSet, TactileEncoding};
use rayon::prelude::*;
use serde::Serialize;
use snn::engine::{Engine, Mode};
use snn::model_file::{Readout, SnnConfig, SnnModel};
use snn::network::Network;
use std::path::Path;

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

/// Runs every sample through the event-driven engine in `mode` and scores the readout.
pub fn snn_accuracy(network: &Network, config: &SnnConfig, set: &SpikeSet, mode: Mode) -> Result<Scored> {
    let engine = Engine::new(network, config.dt_us, mode)?;
    let n_out = engine.n_outputs();
    let results: Vec<(Vec<f32>, u64, u64)> = set
        .trains
        .par_iter()
        .map_init(
            || engine.state(0),
            |st, train| -> Result<(Vec<f32>, u64, u64)> {
                engine.run_train(st, train)?;
                let readout = match config.readout {
                    Readout::MaxMembrane => st.output_v_max().to_vec(),
                    Readout::SpikeCount => st.output_counts(n_out).into_iter().map(|c| c as f32).collect(),
                };
                Ok((readout, st.stats.synops, st.stats.spikes.iter().sum()))
            },
        )
        .collect::<Result<_>>()?;
    let mut confusion = Confusion::new(set.classes.len().max(n_out));
    let (mut synops, mut spikes) = (0u64, 0u64);
    // sensor events (a step's several events at one input reach the engine as one weighted input)
    let inputs: u64 = set.trains.iter().map(|t| t.total()).sum();
    let mut predictions = Vec::with_capacity(results.len());
    for ((readout, s, z), &label) in results.into_iter().zip(&set.labels) {
        let pred = argmax(readout.iter().copied());
        confusion.add(label, pred);
        synops += s;
        spikes += z;
        predictions.push((pred, readout));
    }
    let n = set.len().max(1) as f64;
    Ok(Scored {
        accuracy: confusion.accuracy(),
        n: set.len(),
        correct: confusion.correct() as usize,
        synops_per_sample: synops as f64 / n,
        spikes_per_sample: spikes as f64 / n,
        input_events_per_sample: inputs as f64 / n,
        confusion: confusion.counts,
        predictions,
    })
}

/// Whether the engine's async mode runs this network (the engine's own rule: LIF and IF layers
/// without bias or recurrence).
pub fn async_capable(network: &Network, dt_us: i64) -> bool {
    Engine::new(network, dt_us, Mode::Async).is_ok()
}

/// Which samples of a dataset folder to score.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SplitChoice {
    Train,
    /// The validation hold-out of the train split that training kept with the same share and
    /// seed.
    Validation {
        fraction: f64,
        seed: u64,
    },
    Test,
    All,
}

impl SplitChoice {
    pub fn name(self) -> &'static str {
        match self {
            SplitChoice::Train => "train",
            SplitChoice::Validation { .. } => "validation",
            SplitChoice::Test => "test",
            SplitChoice::All => "all",
        }
    }
}

/// A model's tactile encoding, from its header (`path` names it in errors).
pub fn encoding_of(model: &SnnModel, path: &Path) -> Result<TactileEncoding> {
    serde_json::from_value(model.preprocess.clone())
        .map_err(|e| Error::Invalid(format!("{}: header `preprocess` is not a tactile encoding: {e}", path.display())))
}

/// The samples of `split` of the dataset folder `data_dir`, encoded as the model was trained.
pub fn load_split(data_dir: &Path, encoding: &TactileEncoding, split: SplitChoice) -> Result<SpikeSet> {
    let data = Dataset::load(data_dir, encoding.period_us)?;
    let base = match split {
        SplitChoice::Train | SplitChoice::Validation { .. } => Some(Split::Train),
        SplitChoice::Test => Some(Split::Test),
        SplitChoice::All => None,
    };
    let set = encoding.encode(&data, base)?;
    Ok(match split {
        SplitChoice::Validation { fraction, seed } => {
            if !(fraction > 0.0 && fraction < 1.0) {
                return Err(Error::Invalid(format!("the validation share must lie between 0 and 1, got {fraction}")));
            }
            set.stratified_split(fraction, seed).1
        }
        _ => set,
    })
}

/// Per sample: `index,truth,predicted,` and one readout column per class (CSV; a class name with
/// a comma, quote or line break is quoted as RFC 4180 says).
pub fn predictions_csv(classes: &[String], labels: &[usize], predictions: &[(usize, Vec<f32>)]) -> String {
    use std::fmt::Write as _;
    let field = |s: &str| {
        if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
    };
    let mut out = String::from("index,truth,predicted");
    for c in classes {
        let _ = write!(out, ",{}", field(&format!("readout_{c}")));
    }
    out.push('\n');
    for (k, (&label, (pred, readout))) in labels.iter().zip(predictions).enumerate() {
        let _ = write!(out, "{k},{},{}", field(&classes[label]), field(&classes[*pred]));
        for v in readout {
            let _ = write!(out, ",{v}");
        }
        out.push('\n');
    }
    out
}
