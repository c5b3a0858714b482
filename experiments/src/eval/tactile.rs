//! Tactile datasets (folders in the iCub layout, real recordings): an SNN's accuracy and work on a
//! split, run by the event-driven engine (`braille eval --data`).

use crate::error::{Error, Result};
use crate::eval::scoring::{Confusion, argmax};
use encoders::dataset::{Dataset, Split};
use learn::data::{SpikeSet, TactileEncoding};
use pipeline::models::Preprocessing;
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
    Ok(score_readouts(set, n_out, results))
}

/// Scores each sample's readout (with its synaptic operations and spikes) against the set's
/// labels: the predicted class is the readout's argmax.
pub(crate) fn score_readouts(set: &SpikeSet, n_out: usize, results: Vec<(Vec<f32>, u64, u64)>) -> Scored {
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
    Scored {
        accuracy: confusion.accuracy(),
        n: set.len(),
        correct: confusion.correct() as usize,
        synops_per_sample: synops as f64 / n,
        spikes_per_sample: spikes as f64 / n,
        input_events_per_sample: inputs as f64 / n,
        confusion: confusion.counts,
        predictions,
    }
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

/// A model's tactile encoding, from its typed header (`path` names it in errors).
pub fn encoding_of(model: &SnnModel, path: &Path) -> Result<TactileEncoding> {
    match Preprocessing::of_header(&model.preprocess, path)? {
        Preprocessing::Tactile(e) => Ok(e),
        other => Err(pipeline::Error::Header {
            path: path.to_path_buf(),
            key: "preprocess",
            expected: "a tactile encoding",
            found: other.kind().to_string(),
        }
        .into()),
    }
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
                return Err(Error::Setting {
                    name: "validation share",
                    value: fraction.to_string(),
                    expected: "between 0 and 1",
                });
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

/// A text spelled as one event stream from recorded letters (real data): each letter a test-split
/// sample of an analog dataset, sigma-delta encoded from pressure (255 - reading), one after the
/// other every `sample_us`.
pub struct SpelledStream {
    pub events: Vec<encoders::Event>,
    pub text: String,
    pub sample_us: i64,
    /// Events of every sample of the dataset, encoded.
    pub encoded_events: usize,
    pub samples: usize,
}

/// Spells `text` (A-Z and spaces, as the dataset's classes name them) from test-split samples of
/// the analog dataset `ds`.
pub fn spell_stream(ds: &Dataset, text: &str, threshold: f32, period_us: i64) -> Result<SpelledStream> {
    use encoders::dataset::SampleData;
    let cfg = encoders::sigma_delta::SigmaDeltaConfig { threshold, interpolate: false };
    let mut encoded = Vec::with_capacity(ds.samples.len());
    for s in &ds.samples {
        let SampleData::Analog { frames } = &s.data else {
            return Err(Error::Data {
                path: ds.dir.clone(),
                what: "holds event data; spelling encodes analog data".into(),
            });
        };
        let pressure: Vec<f32> = frames.iter().map(|v| 255.0 - v).collect();
        encoded.push((s.label, s.split, encoders::sigma_delta::encode(&cfg, &pressure, ds.channels, period_us)?));
    }
    let sample_us = 2_000_000i64;
    let (mut events, mut spelled, mut offset_us) = (Vec::new(), String::new(), 0i64);
    for ch in text.to_uppercase().chars() {
        let name = if ch == ' ' { "Space".to_string() } else { ch.to_string() };
        let Some(label) = ds.classes.iter().position(|c| *c == name) else {
            return Err(Error::Data {
                path: ds.dir.clone(),
                what: format!("no class {name:?}; classes: {}", ds.classes.join(" ")),
            });
        };
        let Some((_, _, ev)) = encoded.iter().find(|(l, s, _)| *l == label && *s == Split::Test) else {
            return Err(Error::Data { path: ds.dir.clone(), what: format!("no test sample of {name:?}") });
        };
        events.extend(ev.iter().map(|e| encoders::Event { t_us: e.t_us + offset_us, ..*e }));
        spelled.push(ch);
        offset_us += sample_us;
    }
    Ok(SpelledStream {
        events,
        text: spelled,
        sample_us,
        encoded_events: encoded.iter().map(|e| e.2.len()).sum(),
        samples: encoded.len(),
    })
}

/// A tactile SNN reads a spelled stream letter by letter (each letter's slice of `sample_us`) on
/// the event-driven engine: the letters read and the synaptic operations. The stream encodes
/// pressure; the model was trained on the readings as recorded, whose sigma-delta events are the
/// same with ON and OFF swapped.
pub fn read_letters(
    model: &SnnModel,
    path: &Path,
    stream: &[encoders::Event],
    resolution: encoders::Resolution,
    letters: usize,
    sample_us: i64,
) -> Result<(String, u64)> {
    let enc = encoding_of(model, path)?;
    let encoder = enc.encoder(resolution)?;
    let engine = Engine::new(&model.network, model.config.dt_us, Mode::Stepped)?;
    let mut state = engine.state(0);
    let (mut read, mut synops) = (String::new(), 0u64);
    for i in 0..letters as i64 {
        let (a, b) = (i * sample_us, (i + 1) * sample_us);
        let lo = stream.partition_point(|e| e.t_us < a);
        let hi = stream.partition_point(|e| e.t_us < b);
        let letter: Vec<encoders::Event> = stream[lo..hi]
            .iter()
            .map(|e| encoders::Event {
                t_us: e.t_us - a,
                polarity: encoders::Polarity::from_on(!e.polarity.is_on()),
                ..*e
            })
            .collect();
        engine.reset(&mut state, 0);
        engine.run_train(&mut state, &encoder.encode(&letter, 0, enc.steps))?;
        synops += state.stats.synops;
        let best = argmax(state.output_v_max().iter().copied());
        read.push(match model.classes.get(best).map(String::as_str) {
            Some("Space") => ' ',
            Some(c) => c.chars().next().unwrap_or('?'),
            None => '?',
        });
    }
    Ok((read, synops))
}

/// A model's score on a dataset folder's split (`braille eval --data`).
#[derive(Debug, Clone, Serialize)]
pub struct SplitEval {
    pub data: String,
    pub split: &'static str,
    pub model: String,
    pub mode: &'static str,
    pub accuracy: f64,
    pub n: usize,
    pub correct: usize,
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    pub input_events_per_sample: f64,
}

/// The line `braille eval --data` prints.
impl std::fmt::Display for SplitEval {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} ({} split, {} samples): accuracy {:.2}% ({} engine); {:.0} synops, {:.0} spikes, {:.1} input events per sample",
            self.data,
            self.split,
            self.n,
            100.0 * self.accuracy,
            self.mode,
            self.synops_per_sample,
            self.spikes_per_sample,
            self.input_events_per_sample
        )
    }
}

/// The SNN at `model_path` on `split` of the dataset folder `data_dir`, run by the engine in
/// `mode`; with each sample's truth, prediction and readout as CSV ([`predictions_csv`]).
pub fn eval_split(model_path: &Path, data_dir: &Path, split: SplitChoice, mode: Mode) -> Result<(SplitEval, String)> {
    eval_model(&pipeline::models::load_snn(model_path)?, model_path, data_dir, split, mode)
}

/// As [`eval_split`], for a model in memory (a merged ensemble, say); `model_path` names it in
/// errors and in the result.
pub fn eval_model(
    model: &SnnModel,
    model_path: &Path,
    data_dir: &Path,
    split: SplitChoice,
    mode: Mode,
) -> Result<(SplitEval, String)> {
    let encoding = encoding_of(model, model_path)?;
    let set = load_split(data_dir, &encoding, split)?;
    let s = snn_accuracy(&model.network, &model.config, &set, mode)?;
    let csv = predictions_csv(&model.classes, &set.labels, &s.predictions);
    let mode = match mode {
        Mode::Stepped => "stepped",
        Mode::Async => "async",
    };
    Ok((SplitEval::of(data_dir, split, model_path, mode, &s), csv))
}

impl SplitEval {
    /// A split's score: where it came from, and how the model ran (`mode`).
    pub fn of(data_dir: &Path, split: SplitChoice, model_path: &Path, mode: &'static str, s: &Scored) -> SplitEval {
        SplitEval {
            data: data_dir.display().to_string(),
            split: split.name(),
            model: model_path.display().to_string(),
            mode,
            accuracy: s.accuracy,
            n: s.n,
            correct: s.correct,
            synops_per_sample: s.synops_per_sample,
            spikes_per_sample: s.spikes_per_sample,
            input_events_per_sample: s.input_events_per_sample,
        }
    }
}
