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
use snn::chip::Chip;
use snn::chip::xylo::{self, Quantisation, Run, Xylo, XyloSpec, XyloStats};
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

/// Every sample of `set` through `spec` as Xylo computes: accuracy and work, scored as the float
/// engine's ([`crate::eval::tactile::snn_accuracy`]).
pub fn xylo_accuracy(chip: &Xylo, set: &SpikeSet, run: Run) -> Result<(Scored, f64)> {
    let spec = chip.spec();
    let results: Vec<(Vec<f32>, XyloStats)> = set
        .trains
        .par_iter()
        .map(|t| chip.run_sample((0..t.n_steps()).map(|k| t.step(k)), run).map_err(Error::from))
        .collect::<Result<_>>()?;
    let n = set.len().max(1) as f64;
    let updates: u64 = results.iter().map(|(_, s)| s.neuron_updates).sum();
    let results = results.into_iter().map(|(r, s)| (r, s.synops, s.hidden_spikes + s.output_spikes)).collect();
    Ok((score_readouts(set, spec.n_out, results), updates as f64 / n))
}

/// A model file's network mapped to Xylo, read out as the model file says (the highest output
/// membrane, or output spikes counted).
fn map_model(model: &snn::model_file::SnnModel, path: &Path, quantisation: Quantisation) -> Result<xylo::Mapped> {
    let mut mapped = xylo::map(&model.network, quantisation).map_err(|source| Error::Engine {
        what: path.display().to_string(),
        source,
        hint: "",
    })?;
    mapped.spec.readout = model.config.readout.into();
    Ok(mapped)
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
) -> Result<(ChipEval, String, Option<XyloTrace>)> {
    let model = pipeline::models::load_snn(model_path)?;
    let encoding = encoding_of(&model, model_path)?;
    let set = load_split(data_dir, &encoding, split)?;
    let Chip::Xylo = choice.chip;
    let mapped = map_model(&model, model_path, choice.quantisation)?;
    let chip = mapped.spec.clone().compile()?;
    let (s, updates) = xylo_accuracy(&chip, &set, choice.run)?;
    let csv = predictions_csv(&model.classes, &set.labels, &s.predictions);
    let mode = match choice.run {
        Run::Stepped => "stepped",
        Run::EventDriven => "event-driven",
    };
    let eval = ChipEval {
        eval: SplitEval::of(data_dir, split, model_path, mode, &s),
        chip: choice,
        approximations: mapped.approximations.iter().map(ToString::to_string).collect(),
        weight_shifts: [mapped.spec.weight_shift_in, mapped.spec.weight_shift_rec, mapped.spec.weight_shift_out],
        neuron_updates_per_sample: updates,
    };
    let trace = if trace {
        Some(XyloTrace {
            model: model_path.display().to_string(),
            data: data_dir.display().to_string(),
            split: split.name(),
            quantisation: choice.quantisation,
            samples: trace_samples(&chip, &set, choice.run, progress)?,
            spec: mapped.spec,
        })
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

/// Every sample of `set` through `chip`, each step recorded.
fn trace_samples(chip: &Xylo, set: &SpikeSet, run: Run, progress: &dyn Progress) -> Result<Vec<SampleTrace>> {
    let n_in = chip.spec().n_in;
    progress.start("Xylo trace", set.len() as u64);
    let samples = set
        .trains
        .iter()
        .zip(&set.labels)
        .map(|(t, &label)| {
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
            progress.inc();
            Ok(s)
        })
        .collect::<Result<Vec<_>>>()?;
    progress.finish();
    Ok(samples)
}
