//! A trained SNN in a chip's arithmetic on a dataset folder's split (`braille eval --chip`): the
//! model mapped into the chip's number formats ([`snn::chip`]), every sample run as the chip
//! computes, scored as the float engine is scored; and a trace of every sample (inputs, hidden
//! spikes, output membranes) for a spike-for-spike check against the vendor's simulator.

use crate::Progress;
use crate::error::{Error, Result};
use crate::eval::scoring::argmax;
use crate::eval::tactile::{Scored, SplitChoice, SplitEval, encoding_of, load_split, predictions_csv, score_readouts};
use learn::data::SpikeSet;
use rayon::prelude::*;
use serde::Serialize;
use snn::chip::loihi2::{Loihi2, Loihi2Spec};
use snn::chip::speck::{Speck, SpeckSpec};
use snn::chip::xylo::{Quantisation, Run, Xylo, XyloSpec};
use snn::chip::{Chip, ChipModel, ChipWork, MappedModel};
use std::path::Path;

/// Which chip's arithmetic, quantised how, visited how.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ChipChoice {
    pub chip: Chip,
    pub quantisation: Quantisation,
    pub run: Run,
}

/// A model's score on a split in a chip's arithmetic.
#[derive(Debug, Clone, Serialize)]
pub struct ChipEval {
    #[serde(flatten)]
    pub eval: SplitEval,
    pub chip: ChipChoice,
    /// What the mapping changed (decays rounded to bit shifts, reset by subtraction, ...).
    pub approximations: Vec<String>,
    /// The mapped model's bit shifts of the input, recurrent and output weights.
    pub weight_shifts: [u8; 3],
    pub neuron_updates_per_sample: f64,
}

/// What `braille eval --data --chip` prints: the score in the chip's arithmetic, then what the
/// mapping changed.
impl std::fmt::Display for ChipEval {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let e = &self.eval;
        writeln!(
            f,
            "{} ({} split, {} samples) in {}'s arithmetic ({:?} quantisation, weight shifts {:?}, {} run): accuracy {:.2}%; {:.0} synops, {:.0} spikes, {:.0} neuron updates, {:.1} input events per sample",
            e.data,
            e.split,
            e.n,
            self.chip.chip,
            self.chip.quantisation,
            self.weight_shifts,
            e.mode,
            100.0 * e.accuracy,
            e.synops_per_sample,
            e.spikes_per_sample,
            self.neuron_updates_per_sample,
            e.input_events_per_sample
        )?;
        writeln!(f, "what the mapping changed:")?;
        self.approximations.iter().try_for_each(|a| writeln!(f, "  {a}"))
    }
}

/// Every sample of `set` through `chip` as the chip computes: accuracy and work, scored as the
/// float engine's ([`crate::eval::tactile::snn_accuracy`]), and neuron updates per sample.
pub fn chip_accuracy(chip: &ChipModel, set: &SpikeSet, run: Run) -> Result<(Scored, f64)> {
    let results: Vec<(Vec<f32>, ChipWork)> = set
        .trains
        .par_iter()
        .map(|t| chip.run_sample((0..t.n_steps()).map(|k| t.step(k)), run).map_err(Error::from))
        .collect::<Result<_>>()?;
    let n = set.len().max(1) as f64;
    let updates: u64 = results.iter().map(|(_, s)| s.neuron_updates).sum();
    let results = results.into_iter().map(|(r, s)| (r, s.synops, s.spikes)).collect();
    Ok((score_readouts(set, chip.n_out(), results), updates as f64 / n))
}

/// A model file's network mapped to `choice`'s chip, read out as the model file says (the
/// highest output membrane, or output spikes counted).
pub fn map_model(model: &snn::model_file::SnnModel, path: &Path, choice: ChipChoice) -> Result<MappedModel> {
    ChipModel::map(&model.network, choice.chip, choice.quantisation, model.config.readout)
        .map_err(|source| Error::Engine { what: path.display().to_string(), source, hint: "" })
}

/// The SNN at `model_path` on `split` of `data_dir` in `choice`'s arithmetic; with each sample's
/// truth, prediction and readout as CSV, and with `trace`, every sample as the chip ran it (the
/// same model, mapping and samples).
pub fn eval_split_chip(
    model_path: &Path,
    data_dir: &Path,
    split: SplitChoice,
    choice: ChipChoice,
    trace: bool,
    progress: &dyn Progress,
) -> Result<(ChipEval, String, Option<ChipTrace>)> {
    let model = pipeline::models::load_snn(model_path)?;
    let encoding = encoding_of(&model, model_path)?;
    let set = load_split(data_dir, &encoding, split)?;
    let mapped = map_model(&model, model_path, choice)?;
    let (s, updates) = chip_accuracy(&mapped.model, &set, choice.run)?;
    let csv = predictions_csv(&model.classes, &set.labels, &s.predictions);
    let mode = match choice.run {
        Run::Stepped => "stepped",
        Run::EventDriven => "event-driven",
    };
    let eval = ChipEval {
        eval: SplitEval::of(data_dir, split, model_path, mode, &s),
        chip: choice,
        approximations: mapped.approximations.clone(),
        weight_shifts: mapped.weight_shifts,
        neuron_updates_per_sample: updates,
    };
    let trace = if trace {
        Some(ChipTrace::of(
            &mapped.model,
            &model,
            model_path,
            data_dir.display().to_string(),
            split.name(),
            choice,
            &set,
            progress,
        )?)
    } else {
        None
    };
    Ok((eval, csv, trace))
}

/// One sample as Xylo ran it.
#[derive(Debug, Clone, Serialize)]
pub struct SampleTrace {
    pub label: usize,
    pub predicted: usize,
    /// `[step][channel]` input events as encoded (before the chip's cap of 15).
    pub input: Vec<Vec<u16>>,
    /// `[step, neuron, spikes]` of every hidden neuron that spiked.
    pub hidden_spikes: Vec<[u32; 3]>,
    /// `[step][output]` membranes after each step.
    pub v_mem_out: Vec<Vec<i16>>,
    /// `[step][output]` spikes.
    pub out_spikes: Vec<Vec<u8>>,
}

/// A model mapped to Xylo and every sample of a split as it ran: what a vendor's simulator needs
/// to run the same samples, and what it must give.
#[derive(Debug, Clone, Serialize)]
pub struct XyloTrace {
    pub model: String,
    pub data: String,
    pub split: &'static str,
    pub quantisation: Quantisation,
    pub spec: XyloSpec,
    pub samples: Vec<SampleTrace>,
}

/// One sample as Speck ran it, sparse.
#[derive(Debug, Clone, Serialize)]
pub struct SpeckSampleTrace {
    pub label: usize,
    pub predicted: usize,
    pub steps: usize,
    /// `[step, channel, events]` of every input channel with events.
    pub input: Vec<[u32; 3]>,
    /// `[step, core, neuron, spikes]` of every neuron that spiked (before pooling).
    pub spikes: Vec<[u32; 4]>,
    /// Output spikes per output neuron over the sample.
    pub out_counts: Vec<u32>,
}

/// The float parameters a Speck core was quantised from, for a check of the quantiser.
#[derive(Debug, Clone, Serialize)]
pub struct FloatCore {
    pub weights: Vec<f32>,
    pub threshold: f32,
}

/// A model mapped to Speck and every sample as it ran.
#[derive(Debug, Clone, Serialize)]
pub struct SpeckTrace {
    pub model: String,
    pub data: String,
    pub split: &'static str,
    pub spec: SpeckSpec,
    pub float: Vec<FloatCore>,
    pub samples: Vec<SpeckSampleTrace>,
}

/// One sample as Loihi 2 ran it, sparse, its drain steps included.
#[derive(Debug, Clone, Serialize)]
pub struct Loihi2SampleTrace {
    pub label: usize,
    pub predicted: usize,
    /// Steps run: the sample's, then the drain steps without input.
    pub steps: usize,
    /// `[step, channel, events]` of every input channel with events.
    pub input: Vec<[u32; 3]>,
    /// `[step, layer, neuron]` of every spike.
    pub spikes: Vec<[u32; 3]>,
    /// `[step][output]` membranes after each step.
    pub v_out: Vec<Vec<i32>>,
}

/// A model mapped to Loihi 2 and every sample as it ran.
#[derive(Debug, Clone, Serialize)]
pub struct Loihi2Trace {
    pub model: String,
    pub data: String,
    pub split: &'static str,
    pub spec: Loihi2Spec,
    pub samples: Vec<Loihi2SampleTrace>,
}

/// Every sample as the chip ran it (`braille eval --chip ... --trace`).
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "chip", rename_all = "lowercase")]
pub enum ChipTrace {
    Xylo(Box<XyloTrace>),
    Speck(SpeckTrace),
    Loihi2(Loihi2Trace),
}

impl ChipTrace {
    /// Runs every sample of `set` through `chip`, each step recorded.
    #[allow(clippy::too_many_arguments)]
    pub fn of(
        chip: &ChipModel,
        model: &snn::model_file::SnnModel,
        model_path: &Path,
        data: String,
        split: &'static str,
        choice: ChipChoice,
        set: &SpikeSet,
        progress: &dyn Progress,
    ) -> Result<ChipTrace> {
        let model_name = model_path.display().to_string();
        Ok(match chip {
            ChipModel::Xylo(x) => ChipTrace::Xylo(Box::new(XyloTrace {
                model: model_name,
                data,
                split,
                quantisation: choice.quantisation,
                spec: x.spec().clone(),
                samples: trace_xylo(x, set, choice.run, progress)?,
            })),
            ChipModel::Speck(s) => ChipTrace::Speck(SpeckTrace {
                model: model_name,
                data,
                split,
                spec: s.spec().clone(),
                float: model
                    .network
                    .layers
                    .iter()
                    .filter_map(|l| match (&l.op, l.neurons) {
                        (snn::network::Op::Conv2d { weight, .. } | snn::network::Op::Dense { weight, .. }, Some(p)) => {
                            Some(FloatCore { weights: weight.clone(), threshold: p.v_th })
                        }
                        _ => None,
                    })
                    .collect(),
                samples: trace_speck(s, set, choice.run, progress)?,
            }),
            ChipModel::Loihi2(l) => ChipTrace::Loihi2(Loihi2Trace {
                model: model_name,
                data,
                split,
                spec: l.spec().clone(),
                samples: trace_loihi2(l, set, choice.run, progress)?,
            }),
        })
    }
}

/// `record` on every sample of `set` (its spike train and label), in order, with progress.
fn trace_each<T>(
    set: &SpikeSet,
    what: &str,
    progress: &dyn Progress,
    record: impl Fn(&encoders::spike_train::SpikeTrain, usize) -> Result<T>,
) -> Result<Vec<T>> {
    progress.start(what, set.len() as u64);
    let samples = set
        .trains
        .iter()
        .zip(&set.labels)
        .map(|(t, &label)| {
            let s = record(t, label)?;
            progress.inc();
            Ok(s)
        })
        .collect::<Result<Vec<_>>>()?;
    progress.finish();
    Ok(samples)
}

/// Every sample of `set` through `chip`, each step recorded.
fn trace_xylo(chip: &Xylo, set: &SpikeSet, run: Run, progress: &dyn Progress) -> Result<Vec<SampleTrace>> {
    let n_in = chip.spec().n_in;
    trace_each(set, "Xylo trace", progress, |t, label| {
        let mut st = chip.state();
        let mut s = SampleTrace {
            label,
            predicted: 0,
            input: Vec::new(),
            hidden_spikes: Vec::new(),
            v_mem_out: Vec::new(),
            out_spikes: Vec::new(),
        };
        for k in 0..t.n_steps() {
            let (channels, events) = t.step(k);
            let mut row = vec![0u16; n_in];
            for (&c, &n) in channels.iter().zip(events) {
                row[c as usize] = n;
            }
            s.input.push(row);
            chip.step(&mut st, channels, events, run)?;
            for (j, &n) in st.spikes.iter().enumerate().filter(|(_, n)| **n > 0) {
                s.hidden_spikes.push([k as u32, j as u32, n as u32]);
            }
            s.v_mem_out.push(st.v_mem_out.clone());
            s.out_spikes.push(st.out_spikes.clone());
        }
        s.predicted = argmax(chip.readout(&st));
        Ok(s)
    })
}

/// Every sample of `set` through Speck, every spike of every core recorded.
fn trace_speck(chip: &Speck, set: &SpikeSet, run: Run, progress: &dyn Progress) -> Result<Vec<SpeckSampleTrace>> {
    trace_each(set, "Speck trace", progress, |t, label| {
        let mut st = chip.state();
        let mut s = SpeckSampleTrace {
            label,
            predicted: 0,
            steps: t.n_steps(),
            input: Vec::new(),
            spikes: Vec::new(),
            out_counts: Vec::new(),
        };
        for k in 0..t.n_steps() {
            let (channels, events) = t.step(k);
            for (&c, &n) in channels.iter().zip(events).filter(|(_, n)| **n > 0) {
                s.input.push([k as u32, c, n as u32]);
            }
            chip.step(&mut st, channels, events, run)?;
            for (core, cs) in st.cores.iter().enumerate() {
                let mut fired = cs.fired().to_vec();
                fired.sort_unstable();
                s.spikes.extend(fired.iter().map(|&j| [k as u32, core as u32, j, cs.spikes[j as usize]]));
            }
        }
        s.out_counts = st.out_spike_counts.clone();
        s.predicted = argmax(chip.readout(&st));
        Ok(s)
    })
}

/// Every sample of `set` through Loihi 2 (its drain steps included), every spike recorded.
fn trace_loihi2(chip: &Loihi2, set: &SpikeSet, run: Run, progress: &dyn Progress) -> Result<Vec<Loihi2SampleTrace>> {
    trace_each(set, "Loihi 2 trace", progress, |t, label| {
        let mut st = chip.state();
        let steps = t.n_steps() + chip.drain_steps();
        let mut s =
            Loihi2SampleTrace { label, predicted: 0, steps, input: Vec::new(), spikes: Vec::new(), v_out: Vec::new() };
        for k in 0..steps {
            let (channels, events) = if k < t.n_steps() { t.step(k) } else { (&[][..], &[][..]) };
            for (&c, &n) in channels.iter().zip(events).filter(|(_, n)| **n > 0) {
                s.input.push([k as u32, c, n as u32]);
            }
            chip.step(&mut st, channels, events, run)?;
            for (layer, ls) in st.layers.iter().enumerate() {
                s.spikes.extend(ls.fired.iter().map(|&j| [k as u32, layer as u32, j]));
            }
            s.v_out.push(st.layers.last().map(|l| l.v.clone()).unwrap_or_default());
        }
        s.predicted = argmax(chip.readout(&st));
        Ok(s)
    })
}
