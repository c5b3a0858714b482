//! Training the SNN with backpropagation through time: Adam, seeded shuffling, a validation set,
//! the best checkpoint kept, early stopping.

use crate::data::SpikeSet;
use crate::snn::{SnnParams, SnnTwin};
use crate::sparse::chip::ChipTarget;
use crate::sparse::{Adam, Distill, Params, SparseSnn, StepEvents};
use burn::module::Module;
use burn::nn::loss::CrossEntropyLossConfig;
use burn::optim::grad_clipping::GradientClippingConfig;
use burn::optim::{AdamConfig, AdamWConfig, GradientsParams};
use burn::tensor::{Device, Int, Tensor, TensorData};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use snn::spec::LayerWeights;
use std::time::Instant;

/// How to train.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    pub epochs: usize,
    pub batch_size: usize,
    /// Adam's learning rate at the start; it follows a cosine down to `lr * lr_final_fraction`.
    pub lr: f64,
    /// The first this many optimiser steps ramp the learning rate up linearly (step k of them at
    /// `k / warmup_steps` of the schedule's rate; 0: no warm-up). The SNN trainers only.
    #[serde(default)]
    pub warmup_steps: usize,
    pub lr_final_fraction: f64,
    pub seed: u64,
    /// Stop when validation accuracy has not improved for this many epochs (0: never).
    pub patience: usize,
    #[serde(default)]
    pub augment: Augment,
    /// Clip the gradient's norm to this (0: no clipping).
    #[serde(default)]
    pub clip_norm: f64,
    /// Decoupled weight decay (AdamW) per unit of learning rate; 0: plain Adam.
    #[serde(default)]
    pub weight_decay: f64,
    /// L2-SP, decoupled (the sparse trainer): every step pulls each weight toward its starting
    /// value by `lr * anchor_decay * (w - w0)`; for fine-tuning, a pull toward the trained model
    /// (0: off).
    #[serde(default)]
    pub anchor_decay: f64,
    /// A guard against a training run's collapse (0: off): an epoch whose mean training loss is
    /// more than this many times the lowest of the epochs before it is undone (the weights of the
    /// epoch before restored, the optimiser's moments forgotten) and the learning rate halved
    /// for the rest of the run. It reads the training loss only; a run whose loss never jumps is
    /// the same with and without it.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub loss_spike_guard: f64,
    /// Layers (by index, 0 the first) that keep their starting weights (the sparse trainer).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frozen_layers: Vec<usize>,
    /// Stochastic weight averaging (0: off): the mean of the weights of the last this many epochs
    /// is a candidate beside each epoch's own, chosen on validation like them; without a
    /// validation set it is taken.
    #[serde(default)]
    pub average_epochs: usize,
    /// Each hidden spiking neuron is silenced with this probability for a whole training sample.
    #[serde(default)]
    pub dropout: f64,
    /// Class-balanced sampling: each epoch draws class c's samples in proportion to
    /// `n_c^(1 - class_balance)`, the epoch as long as the training set (0: every sample once, as
    /// before; 0.5: square-root sampling; 1: every class alike). A class's samples are drawn in
    /// shuffled turns, none twice before all have been drawn ([`epoch_order`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub class_balance: f64,
    /// Which trainer computes an SNN's gradients (records from before the sparse trainer were
    /// trained dense, which is what a record without this field reads as).
    #[serde(default = "Trainer::recorded")]
    pub trainer: Trainer,
    /// The sparse trainer's truncation: surrogate derivatives below this fraction of their peak
    /// count as zero (0: exact gradients).
    #[serde(default)]
    pub gradient_cutoff: f32,
    /// Quantisation-aware training (the sparse trainer): every step's forward pass runs in this
    /// chip's arithmetic with the weights of that step quantised ([`crate::sparse::chip`]), and
    /// checkpoints are chosen on the chip's validation accuracy.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chip: Option<ChipTarget>,
    /// A diagnostic, not part of the recipe (never recorded): with the sparse trainer truncated
    /// (`gradient_cutoff` > 0), every batch of the first and the last epoch also computes the
    /// exact gradient on the same samples and dropout masks (not applied; the run's weights are
    /// unchanged) and the epoch reports how far the truncated one is from it
    /// ([`EpochReport::truncation`]).
    #[serde(skip)]
    pub check_truncation: bool,
}

/// The truncated gradient against the exact one over every batch of an epoch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruncationCheck {
    pub batches: usize,
    /// Cosine between the truncated and the exact gradient (all parameters flattened), per
    /// batch: mean and lowest.
    pub cosine_mean: f64,
    pub cosine_min: f64,
    /// `|g_truncated - g_exact| / |g_exact|`, mean over the batches.
    pub relative_error_mean: f64,
}

impl TruncationCheck {
    /// Cosine and relative error of each batch's pair of gradients.
    pub fn of(pairs: &[(f64, f64)]) -> Option<TruncationCheck> {
        (!pairs.is_empty()).then(|| TruncationCheck {
            batches: pairs.len(),
            cosine_mean: pairs.iter().map(|p| p.0).sum::<f64>() / pairs.len() as f64,
            cosine_min: pairs.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
            relative_error_mean: pairs.iter().map(|p| p.1).sum::<f64>() / pairs.len() as f64,
        })
    }
}

/// Cosine and relative L2 error of gradient `a` against `exact`, all tensors flattened.
pub fn gradient_agreement(a: &crate::sparse::Params, exact: &crate::sparse::Params) -> (f64, f64) {
    let (mut dot, mut aa, mut ee, mut diff) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (x, y) in a.tensors().flatten().zip(exact.tensors().flatten()) {
        let (x, y) = (*x as f64, *y as f64);
        dot += x * y;
        aa += x * x;
        ee += y * y;
        diff += (x - y) * (x - y);
    }
    (dot / (aa.sqrt() * ee.sqrt()), diff.sqrt() / ee.sqrt())
}

/// Which trainer computes an SNN's gradients.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Trainer {
    /// Ours, on spike lists ([`crate::sparse`]).
    Sparse,
    /// burn's autodiff on dense tensors ([`crate::snn::SnnTwin`]), the reference.
    Dense,
}

impl Trainer {
    fn recorded() -> Trainer {
        Trainer::Dense
    }
}

/// Training-time augmentation of input spike trains, drawn per sample from the training seed.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Augment {
    /// Each input event is dropped with this probability.
    pub drop_events: f64,
    /// Time is stretched by a factor drawn uniformly in `1 +- stretch` (the finger sliding a
    /// little faster or slower).
    pub stretch: f64,
    /// Each input event is moved by a whole number of steps drawn uniformly within +- this (an
    /// event moved outside the sample's steps is left out of that training pass).
    #[serde(default)]
    pub event_jitter_us: i64,
}

impl TrainConfig {
    /// The learning rate of `epoch` (from 1): a cosine from `lr` down to `lr * lr_final_fraction`.
    pub fn lr_at(&self, epoch: usize) -> f64 {
        let progress = (epoch - 1) as f64 / (self.epochs.max(2) - 1) as f64;
        self.lr
            * (self.lr_final_fraction
                + (1.0 - self.lr_final_fraction) * 0.5 * (1.0 + (std::f64::consts::PI * progress).cos()))
    }

    /// The learning rate of optimiser step `step` (from 1) where the schedule gives `lr`: ramped
    /// up linearly over the first `warmup_steps` steps.
    pub fn warmed_up(&self, lr: f64, step: usize) -> f64 {
        if step < self.warmup_steps { lr * step as f64 / self.warmup_steps as f64 } else { lr }
    }
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            epochs: 60,
            batch_size: 32,
            lr: 2e-3,
            warmup_steps: 0,
            lr_final_fraction: 0.05,
            seed: 1,
            patience: 0,
            augment: Augment::default(),
            clip_norm: 0.0,
            weight_decay: 0.0,
            anchor_decay: 0.0,
            loss_spike_guard: 0.0,
            frozen_layers: Vec::new(),
            average_epochs: 0,
            dropout: 0.0,
            class_balance: 0.0,
            trainer: Trainer::Sparse,
            gradient_cutoff: crate::sparse::DEFAULT_CUTOFF,
            chip: None,
            check_truncation: false,
        }
    }
}

/// One epoch, as reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EpochReport {
    pub epoch: usize,
    pub lr: f64,
    pub train_loss: f64,
    pub train_accuracy: f64,
    pub val_loss: f64,
    pub val_accuracy: f64,
    /// Mean spikes per sample in each spiking layer (validation).
    pub val_spikes_per_sample: Vec<f64>,
    pub seconds: f64,
    /// With [`TrainConfig::check_truncation`], on the first and the last epoch.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truncation: Option<TruncationCheck>,
    /// Undone by [`TrainConfig::loss_spike_guard`]: its training loss jumped, the weights went
    /// back to the epoch before's and the learning rate was halved (no validation was run).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub undone: bool,
}

/// An epoch's line: its learning rate, loss and accuracy on training and validation, spikes per
/// sample and time; then whether it was undone, and the truncation check where one was run.
impl std::fmt::Display for EpochReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let spikes: Vec<i64> = self.val_spikes_per_sample.iter().map(|s| s.round() as i64).collect();
        write!(
            f,
            "epoch {:>3}: lr {:.2e} train loss {:.3} acc {:5.1}% | val loss {:.3} acc {:5.1}% | spikes/sample {spikes:?} | {:.1} s",
            self.epoch,
            self.lr,
            self.train_loss,
            100.0 * self.train_accuracy,
            self.val_loss,
            100.0 * self.val_accuracy,
            self.seconds
        )?;
        if self.undone {
            write!(
                f,
                "\n           undone (the training loss jumped): back to the weights before it, the learning rate halved"
            )?;
        }
        if let Some(t) = &self.truncation {
            write!(
                f,
                "\nepoch {:>3}: truncated against exact gradient over {} batches: cosine mean {:.4}, lowest {:.4}; relative error mean {:.3}",
                self.epoch, t.batches, t.cosine_mean, t.cosine_min, t.relative_error_mean
            )?;
        }
        Ok(())
    }
}

impl EpochReport {
    /// An epoch of a network without spikes (the ResNet, the conventional baselines): the loss
    /// summed and the hits counted over `n` training samples, validation's loss and accuracy (NaN
    /// without validation), the epoch's start.
    pub fn without_spikes(
        epoch: usize,
        lr: f64,
        (loss_sum, hits, n): (f64, usize, usize),
        (val_loss, val_accuracy): (f64, f64),
        started: Instant,
    ) -> EpochReport {
        EpochReport {
            epoch,
            lr,
            train_loss: loss_sum / n.max(1) as f64,
            train_accuracy: hits as f64 / n.max(1) as f64,
            val_loss,
            val_accuracy,
            val_spikes_per_sample: Vec::new(),
            seconds: started.elapsed().as_secs_f64(),
            truncation: None,
            undone: false,
        }
    }
}

/// Hears about training as it goes (the command line draws progress bars).
pub trait Observer {
    fn epoch_begin(&mut self, _epoch: usize, _batches: usize) {}
    fn batch(&mut self, _loss: f64, _accuracy: f64) {}
    fn epoch_end(&mut self, _report: &EpochReport) {}
}

/// An observer that hears nothing.
pub struct Silent;
impl Observer for Silent {}

/// What training gives: the weights of the best validation epoch, and the history.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub weights: Vec<LayerWeights>,
    pub best_epoch: usize,
    pub best_val_accuracy: f64,
    /// Validation accuracy of the averaged weights (with `average_epochs`), and whether they
    /// were chosen (then `best_epoch` is the last epoch of the average).
    pub average: Option<(f64, bool)>,
    pub history: Vec<EpochReport>,
}

/// The batch `idx` of `set` as one `[batch, n_inputs]` tensor per step.
pub fn batch_input(set: &SpikeSet, idx: &[usize], device: &Device) -> Vec<Tensor<2>> {
    batch_input_augmented(set, idx, device, None)
}

fn batch_input_augmented(
    set: &SpikeSet,
    idx: &[usize],
    device: &Device,
    mut augment: Option<(&Augment, &mut rand_chacha::ChaCha8Rng)>,
) -> Vec<Tensor<2>> {
    let batch: Vec<_> =
        idx.iter().map(|&s| sample_entries(set, s, augment.as_mut().map(|(a, rng)| (*a, &mut **rng)))).collect();
    dense_input(&batch, set.steps, set.n_inputs, device)
}

/// `(step, input, count)` entries of each sample of a batch as one `[batch, n_inputs]` tensor per
/// step, for `steps` steps.
pub fn dense_input(batch: &[crate::sparse::Entries], steps: usize, n_inputs: usize, device: &Device) -> Vec<Tensor<2>> {
    let (b, n) = (batch.len(), n_inputs);
    let mut dense = vec![0f32; steps * b * n];
    for (j, entries) in batch.iter().enumerate() {
        for &(t, i, c) in entries {
            dense[(t as usize * b + j) * n + i as usize] += c;
        }
    }
    dense
        .chunks_exact((b * n).max(1))
        .map(|c| Tensor::<2>::from_data(TensorData::new(c.to_vec(), [b, n]), device))
        .collect()
}

/// Sample `s`'s input as `(step, input, count)` entries, augmented when asked (the draws, in
/// order, are the same whichever trainer takes them).
pub(crate) fn sample_entries(
    set: &SpikeSet,
    s: usize,
    mut augment: Option<(&Augment, &mut rand_chacha::ChaCha8Rng)>,
) -> crate::sparse::Entries {
    use rand::Rng;
    let jitter_steps = match &augment {
        Some((a, _)) if set.dt_us > 0 => (a.event_jitter_us / set.dt_us).max(0),
        _ => 0,
    };
    let mut out = Vec::new();
    let train = &set.trains[s];
    let factor = match &mut augment {
        Some((a, rng)) if a.stretch > 0.0 => rng.random_range(1.0 - a.stretch..1.0 + a.stretch),
        _ => 1.0,
    };
    for k in 0..train.n_steps().min(set.steps) {
        let (inputs, counts) = train.step(k);
        let to = if factor == 1.0 { k } else { (k as f64 * factor).round() as usize };
        if to >= set.steps {
            break;
        }
        for (&i, &c) in inputs.iter().zip(counts) {
            let mut c = c as f32;
            if let Some((a, rng)) = &mut augment
                && a.drop_events > 0.0
            {
                c = (0..c as u32).filter(|_| !rng.random_bool(a.drop_events)).count() as f32;
            }
            match &mut augment {
                Some((_, rng)) if jitter_steps > 0 => {
                    for _ in 0..c as u32 {
                        let t = to as i64 + rng.random_range(-jitter_steps..=jitter_steps);
                        if (0..set.steps as i64).contains(&t) {
                            out.push((t as u32, i, 1.0));
                        }
                    }
                }
                _ => out.push((to as u32, i, c)),
            }
        }
    }
    out
}

fn targets(set: &SpikeSet, idx: &[usize], device: &Device) -> Tensor<1, Int> {
    let t: Vec<i64> = idx.iter().map(|&i| set.labels[i] as i64).collect();
    Tensor::<1, Int>::from_data(TensorData::new(t, [idx.len()]), device)
}

fn correct(logits: &Tensor<2>, set: &SpikeSet, idx: &[usize]) -> usize {
    snn::scoring::hits(crate::predicted_classes(logits), idx.iter().map(|&i| set.labels[i]))
}

/// Validation: loss, accuracy and spikes per sample with the time-stepped network (no autodiff).
pub fn evaluate(twin: &SnnTwin, params: &SnnParams, set: &SpikeSet, batch_size: usize) -> (f64, f64, Vec<f64>) {
    let device = Device::flex();
    let loss_fn = CrossEntropyLossConfig::new().init(&device);
    let idx: Vec<usize> = (0..set.len()).collect();
    let (mut loss, mut hits) = (0.0, 0usize);
    let mut spikes: Vec<f64> = Vec::new();
    for chunk in idx.chunks(batch_size.max(1)) {
        let out = twin.forward(params, &batch_input(set, chunk, &device));
        hits += correct(&out.logits, set, chunk);
        loss +=
            loss_fn.forward(out.logits, targets(set, chunk, &device)).into_scalar::<f32>() as f64 * chunk.len() as f64;
        spikes.resize(out.spikes.len(), 0.0);
        for (s, t) in spikes.iter_mut().zip(out.spikes) {
            *s += t.sum().into_scalar::<f32>() as f64;
        }
    }
    let n = set.len().max(1) as f64;
    (loss / n, hits as f64 / n, spikes.into_iter().map(|s| s / n).collect())
}

/// What computes gradients and steps the weights: burn's twin or the sparse trainer.
trait Fitter {
    /// One optimiser step on the batch `idx` of `set` at `lr`: the batch's mean loss and hits.
    fn step(&mut self, set: &SpikeSet, idx: &[usize], lr: f64, rng: &mut ChaCha8Rng) -> snn::Result<(f64, usize)>;
    /// The current weights, in engine layouts.
    fn weights(&self) -> snn::Result<Vec<LayerWeights>>;
    /// Validation loss, accuracy and spikes per sample (per spiking layer) of `weights`.
    fn evaluate(&self, weights: &[LayerWeights], set: &SpikeSet) -> snn::Result<(f64, f64, Vec<f64>)>;
    /// Whether the coming steps also compare their gradient with the exact one (a truncated
    /// sparse trainer only); the steps' (cosine, relative error) since the last call.
    fn check_truncation(&mut self, _on: bool) -> snn::Result<Vec<(f64, f64)>> {
        Ok(Vec::new())
    }
    /// Goes back to `weights` with the optimiser's moments forgotten.
    fn restore(&mut self, weights: &[LayerWeights]) -> snn::Result<()>;
}

/// burn's autodiff on the dense twin.
struct DenseFitter<'a> {
    twin: &'a SnnTwin,
    params: Option<SnnParams>,
    optim: burn::optim::ModuleOptimizer,
    /// To make the optimiser again ([`Fitter::restore`]).
    cfg: TrainConfig,
    loss_fn: burn::nn::loss::CrossEntropyLoss,
    device: Device,
    dropout: f64,
    augment: Augment,
}

impl Fitter for DenseFitter<'_> {
    fn step(&mut self, set: &SpikeSet, idx: &[usize], lr: f64, rng: &mut ChaCha8Rng) -> snn::Result<(f64, usize)> {
        let input = batch_input_augmented(set, idx, &self.device, Some((&self.augment, rng)));
        let params = self.params.take().expect("parameters between steps");
        let out = self.twin.forward_dropout(&params, &input, self.dropout);
        let h = correct(&out.logits, set, idx);
        let loss = self.loss_fn.forward(out.logits, targets(set, idx, &self.device));
        let l = loss.clone().into_scalar::<f32>() as f64;
        let grads = GradientsParams::from_grads(loss.backward(), &params);
        self.params = Some(self.optim.step(lr, params, grads));
        Ok((l, h))
    }

    fn weights(&self) -> snn::Result<Vec<LayerWeights>> {
        self.params.as_ref().expect("parameters between steps").valid().weights(&self.twin.spec)
    }

    fn restore(&mut self, weights: &[LayerWeights]) -> snn::Result<()> {
        self.params = Some(SnnParams::from_weights(&self.twin.spec, weights, &self.device)?);
        self.optim = dense_optimiser(&self.cfg);
        Ok(())
    }

    fn evaluate(&self, weights: &[LayerWeights], set: &SpikeSet) -> snn::Result<(f64, f64, Vec<f64>)> {
        Ok(evaluate(self.twin, &SnnParams::from_weights(&self.twin.spec, weights, &Device::flex())?, set, 64))
    }
}

/// Ours, on spike lists ([`crate::sparse`]).
struct SparseFitter {
    net: SparseSnn,
    params: Params,
    adam: Adam,
    dropout: f64,
    augment: Augment,
    /// Dropout masks' generator (the augmentation draws from the loop's).
    masks: ChaCha8Rng,
    /// The same network with exact gradients, while the truncation is checked; each checked
    /// step's (cosine, relative error).
    exact: Option<SparseSnn>,
    checked: Vec<(f64, f64)>,
    /// Quantisation-aware: the chip every forward pass runs on.
    chip: Option<ChipTarget>,
    /// Knowledge distillation: the teacher's logits for each training sample.
    teacher: Option<Teacher>,
}

impl SparseFitter {
    fn events(&self, set: &SpikeSet, s: usize, augment: Option<(&Augment, &mut ChaCha8Rng)>) -> StepEvents {
        self.net.input_events(StepEvents::from_entries(set.steps, &mut sample_entries(set, s, augment)))
    }
}

impl Fitter for SparseFitter {
    fn step(&mut self, set: &SpikeSet, idx: &[usize], lr: f64, rng: &mut ChaCha8Rng) -> snn::Result<(f64, usize)> {
        let augment = self.augment;
        let events: Vec<StepEvents> = idx.iter().map(|&s| self.events(set, s, Some((&augment, &mut *rng)))).collect();
        let masks: Vec<_> = idx.iter().map(|_| self.net.dropout_masks(self.dropout, &mut self.masks)).collect();
        let samples: Vec<(&StepEvents, usize)> = events.iter().zip(idx.iter().map(|&s| set.labels[s])).collect();
        let teacher: Option<(Vec<&[f32]>, Distill)> =
            self.teacher.as_ref().map(|t| (idx.iter().map(|&s| t.logits[s].as_slice()).collect(), t.distill));
        // the float network's gradient of the run's loss (the exact one too, when checked)
        let float = |net: &SparseSnn| match &teacher {
            Some((logits, d)) => net.distilled_gradient(&self.params, &samples, &masks, logits, *d),
            None => net.batch_gradient(&self.params, &samples, &masks),
        };
        let g = match self.chip {
            Some(target) => {
                let chip = self.net.chip_forward(&self.params, target)?;
                self.net.chip_batch_gradient(&self.params, &chip, &samples)?
            }
            None => float(&self.net),
        };
        if let Some(exact) = &self.exact {
            let e = float(exact);
            self.checked.push(gradient_agreement(&g.grads, &e.grads));
        }
        self.adam.step(&mut self.params, &g.grads, lr);
        Ok((g.loss_sum / idx.len().max(1) as f64, g.hits))
    }

    fn weights(&self) -> snn::Result<Vec<LayerWeights>> {
        self.net.weights(&self.params)
    }

    fn restore(&mut self, weights: &[LayerWeights]) -> snn::Result<()> {
        self.params = self.net.params(weights)?;
        self.adam.restart();
        Ok(())
    }

    fn evaluate(&self, weights: &[LayerWeights], set: &SpikeSet) -> snn::Result<(f64, f64, Vec<f64>)> {
        let params = self.net.params(weights)?;
        let events: Vec<StepEvents> = (0..set.len()).map(|s| self.events(set, s, None)).collect();
        let refs: Vec<&StepEvents> = events.iter().collect();
        let (mut loss, mut hits, mut spikes) = (0.0, 0usize, Vec::<f64>::new());
        let outputs = match self.chip {
            Some(target) => self.net.infer_on_chip(&self.net.chip_forward(&params, target)?, &refs)?,
            None => self.net.infer(&params, &refs),
        };
        for ((logits, s), &label) in outputs.iter().zip(&set.labels) {
            let (l, _, hit) = crate::sparse::cross_entropy(logits, label);
            loss += l;
            hits += hit as usize;
            spikes.resize(s.len(), 0.0);
            spikes.iter_mut().zip(s).for_each(|(a, &b)| *a += b as f64);
        }
        let n = set.len().max(1) as f64;
        Ok((loss / n, hits as f64 / n, spikes.into_iter().map(|s| s / n).collect()))
    }

    fn check_truncation(&mut self, on: bool) -> snn::Result<Vec<(f64, f64)>> {
        self.exact = None;
        if on && self.net.cutoff() > 0.0 && self.chip.is_none() {
            let mut exact = SparseSnn::new(self.net.spec.clone(), self.net.surrogate, self.net.readout, 0.0)?;
            exact.clamped_readout_gradient = self.net.clamped_readout_gradient;
            self.exact = Some(exact);
        }
        Ok(std::mem::take(&mut self.checked))
    }
}

/// A trained network's logits for each training sample (in the training set's order), to
/// distil from: the loss is [`crate::sparse::distillation`]'s.
#[derive(Debug, Clone, PartialEq)]
pub struct Teacher {
    pub logits: Vec<Vec<f32>>,
    pub distill: Distill,
}

/// Trains from `init` on `train`, keeping the weights that do best on `val`, with the trainer
/// `cfg.trainer` asks for.
pub fn train(
    twin: &SnnTwin,
    init: &[LayerWeights],
    train: &SpikeSet,
    val: &SpikeSet,
    cfg: &TrainConfig,
    observer: &mut dyn Observer,
) -> snn::Result<Outcome> {
    train_from(twin, init, train, val, cfg, None, observer)
}

/// [`train`] with knowledge distillation from `teacher` (the sparse trainer, no chip): each
/// training sample learns from its label and from the teacher's logits on it. Validation,
/// checkpoints and the reported validation loss stay the cross-entropy's.
pub fn train_distilled(
    twin: &SnnTwin,
    init: &[LayerWeights],
    train: &SpikeSet,
    val: &SpikeSet,
    cfg: &TrainConfig,
    teacher: &Teacher,
    observer: &mut dyn Observer,
) -> snn::Result<Outcome> {
    let Distill { weight, temperature } = teacher.distill;
    if !((0.0..=1.0).contains(&weight) && temperature > 0.0 && temperature.is_finite()) {
        return Err(snn::Error::input(format!(
            "distillation weight {weight} must lie in [0, 1] and its temperature {temperature} above 0"
        )));
    }
    if teacher.logits.len() != train.len() {
        return Err(snn::Error::input(format!(
            "the teacher has logits for {} samples, the training set {}",
            teacher.logits.len(),
            train.len()
        )));
    }
    let n_out: usize = twin.spec.shapes()?.last().map_or(0, |s| s.output.iter().product());
    if let Some((s, l)) = teacher.logits.iter().enumerate().find(|(_, l)| l.len() != n_out) {
        return Err(snn::Error::input(format!(
            "the teacher's logits for training sample {s} are {}, the network has {n_out} outputs",
            l.len()
        )));
    }
    if cfg.trainer != Trainer::Sparse || cfg.chip.is_some() {
        return Err(snn::Error::input(
            "knowledge distillation runs on the sparse trainer (--trainer sparse), without a chip",
        ));
    }
    train_from(twin, init, train, val, cfg, Some(teacher), observer)
}

fn train_from(
    twin: &SnnTwin,
    init: &[LayerWeights],
    train: &SpikeSet,
    val: &SpikeSet,
    cfg: &TrainConfig,
    teacher: Option<&Teacher>,
    observer: &mut dyn Observer,
) -> snn::Result<Outcome> {
    if train.is_empty() || cfg.batch_size == 0 || cfg.epochs == 0 {
        return Err(snn::Error::input("training needs samples, a batch size and epochs"));
    }
    if !(0.0..1.0).contains(&cfg.dropout)
        || !(0.0..=f64::MAX).contains(&cfg.weight_decay)
        || cfg.augment.event_jitter_us < 0
    {
        return Err(snn::Error::input(format!(
            "dropout {} must lie in [0, 1), weight decay {} and event jitter {} us must not be negative",
            cfg.dropout, cfg.weight_decay, cfg.augment.event_jitter_us
        )));
    }
    if !(0.0..=f64::MAX).contains(&cfg.anchor_decay) {
        return Err(snn::Error::input(format!("anchor decay {} must not be negative", cfg.anchor_decay)));
    }
    check_class_balance(cfg.class_balance)?;
    check_loss_spike_guard(cfg.loss_spike_guard)?;
    if let Some(&l) = cfg.frozen_layers.iter().find(|&&l| l >= init.len()) {
        return Err(snn::Error::input(format!(
            "frozen layer {l}: the network has {} layers (0 to {})",
            init.len(),
            init.len().saturating_sub(1)
        )));
    }
    if !init.is_empty() && (0..init.len()).all(|l| cfg.frozen_layers.contains(&l)) {
        return Err(snn::Error::input("every layer frozen: nothing would train"));
    }
    match cfg.trainer {
        Trainer::Dense if cfg.anchor_decay > 0.0 || !cfg.frozen_layers.is_empty() => Err(snn::Error::input(
            "the anchor decay (L2-SP) and frozen layers run on the sparse trainer (--trainer sparse)",
        )),
        Trainer::Sparse if cfg.chip.is_some_and(|c| c.chip == snn::chip::Chip::Loihi2) => Err(snn::Error::input(
            "quantisation-aware training for Loihi 2 runs on the dense trainer (--trainer dense)",
        )),
        Trainer::Dense if cfg.chip.is_some_and(|c| c.chip == snn::chip::Chip::Xylo) => {
            Err(snn::Error::input("quantisation-aware training for Xylo runs on the sparse trainer (--trainer sparse)"))
        }
        Trainer::Sparse if cfg.chip.is_some_and(|c| c.chip == snn::chip::Chip::Speck) => {
            Err(snn::Error::input("quantisation-aware training for Speck runs on the dense trainer (--trainer dense)"))
        }
        _ if cfg.chip.is_some_and(|c| c.quantisation != snn::chip::xylo::Quantisation::Global)
            && cfg.chip.is_some_and(|c| c.chip == snn::chip::Chip::Speck) =>
        {
            Err(snn::Error::input("Speck has one scale per core: global quantisation only"))
        }
        _ if cfg.chip.is_some() && cfg.dropout > 0.0 => {
            Err(snn::Error::input("quantisation-aware training runs the chip as it is: no dropout (set it to 0)"))
        }
        Trainer::Dense => {
            let chip_twin;
            let twin = match cfg.chip {
                Some(c) => {
                    // a network the chip cannot hold is refused before training, with the rule
                    snn::chip::ChipModel::map(&twin.spec.build(init.to_vec())?, c.chip, c.quantisation, twin.readout)?;
                    chip_twin = SnnTwin { chip: Some(c.chip), ..twin.clone() };
                    &chip_twin
                }
                None => twin,
            };
            let device = Device::flex().autodiff();
            device.seed(cfg.seed);
            let mut fitter = DenseFitter {
                twin,
                params: Some(SnnParams::from_weights(&twin.spec, init, &device)?),
                optim: dense_optimiser(cfg),
                cfg: cfg.clone(),
                loss_fn: CrossEntropyLossConfig::new().init(&device),
                device,
                dropout: cfg.dropout,
                augment: cfg.augment,
            };
            fit(&mut fitter, init, train, val, cfg, observer)
        }
        Trainer::Sparse => {
            let mut net = SparseSnn::new(twin.spec.clone(), twin.surrogate, twin.readout, cfg.gradient_cutoff)?;
            net.clamped_readout_gradient = twin.clamped_readout_gradient;
            let params = net.params(init)?;
            let frozen = (0..init.len()).map(|l| cfg.frozen_layers.contains(&l)).collect();
            let adam = Adam::new(&params, cfg.weight_decay as f32, cfg.clip_norm as f32)
                .with_anchor(&params, cfg.anchor_decay as f32)
                .with_frozen(frozen);
            let masks = ChaCha8Rng::seed_from_u64(cfg.seed ^ 0x6d61_736b);
            let mut fitter = SparseFitter {
                net,
                params,
                adam,
                dropout: cfg.dropout,
                augment: cfg.augment,
                masks,
                exact: None,
                checked: Vec::new(),
                chip: cfg.chip,
                teacher: teacher.cloned(),
            };
            fit(&mut fitter, init, train, val, cfg, observer)
        }
    }
}

/// burn's Adam (AdamW with a weight decay) as `cfg` asks, each tensor's gradient norm clipped.
fn dense_optimiser(cfg: &TrainConfig) -> burn::optim::ModuleOptimizer {
    let clipping = (cfg.clip_norm > 0.0).then_some(GradientClippingConfig::Norm(cfg.clip_norm as f32));
    if cfg.weight_decay > 0.0 {
        AdamWConfig::new().with_weight_decay(cfg.weight_decay as f32).with_grad_clipping(clipping).init()
    } else {
        AdamConfig::new().with_grad_clipping(clipping).init()
    }
}

/// The training loop: seeded shuffling, the cosine schedule, the best validation epoch kept,
/// weight averaging, early stopping.
fn fit(
    fitter: &mut dyn Fitter,
    init: &[LayerWeights],
    train: &SpikeSet,
    val: &SpikeSet,
    cfg: &TrainConfig,
    observer: &mut dyn Observer,
) -> snn::Result<Outcome> {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut best = (init.to_vec(), 0usize, -1.0f64);
    let mut best_loss = f64::INFINITY;
    let mut history = Vec::new();
    let mut order: Vec<usize> = (0..train.len()).collect();
    let mut turns = ClassTurns::new(&train.labels, train.classes.len(), cfg.class_balance);
    let mut sum: Option<(Vec<LayerWeights>, usize)> = None;
    let mut steps = 0usize;
    // the loss-spike guard: the lowest training loss of the epochs kept, the weights at the end
    // of the last one (the start before any), and the learning rate's factor
    let guard = cfg.loss_spike_guard > 0.0;
    let (mut lowest_loss, mut kept, mut lr_factor) = (f64::INFINITY, guard.then(|| init.to_vec()), 1.0);
    for epoch in 1..=cfg.epochs {
        let start = Instant::now();
        let lr = cfg.lr_at(epoch) * lr_factor;
        epoch_order(&mut order, turns.as_mut(), &mut rng);
        let batches: Vec<&[usize]> = order.chunks(cfg.batch_size).collect();
        observer.epoch_begin(epoch, batches.len());
        fitter.check_truncation(cfg.check_truncation && (epoch == 1 || epoch == cfg.epochs))?;
        let (mut loss_sum, mut hits) = (0.0, 0usize);
        for idx in batches {
            steps += 1;
            let (l, h) = fitter.step(train, idx, cfg.warmed_up(lr, steps), &mut rng)?;
            loss_sum += l * idx.len() as f64;
            hits += h;
            observer.batch(l, h as f64 / idx.len() as f64);
        }
        let truncation = TruncationCheck::of(&fitter.check_truncation(false)?);
        let train_loss = loss_sum / train.len() as f64;
        let undone = guard && train_loss > cfg.loss_spike_guard * lowest_loss;
        let weights = if undone {
            // back to the last kept epoch's weights, at half the learning rate
            fitter.restore(kept.as_deref().expect("kept with the guard"))?;
            lr_factor *= 0.5;
            None
        } else {
            lowest_loss = lowest_loss.min(train_loss);
            let w = fitter.weights()?;
            if guard {
                kept = Some(w.clone());
            }
            Some(w)
        };
        let (val_loss, val_accuracy, val_spikes) = match &weights {
            Some(w) if !val.is_empty() => fitter.evaluate(w, val)?,
            _ => (f64::NAN, f64::NAN, Vec::new()),
        };
        let report = EpochReport {
            epoch,
            lr,
            train_loss,
            train_accuracy: hits as f64 / train.len() as f64,
            val_loss,
            val_accuracy,
            val_spikes_per_sample: val_spikes,
            seconds: start.elapsed().as_secs_f64(),
            truncation,
            undone,
        };
        observer.epoch_end(&report);
        // an undone epoch is neither chosen nor averaged
        let Some(w) = weights else {
            history.push(report);
            continue;
        };
        // The best validation accuracy, ties going to the lower validation loss; without a
        // validation set the last epoch is kept.
        let (score, loss) = if val.is_empty() { (epoch as f64, 0.0) } else { (val_accuracy, val_loss) };
        let improved = score > best.2 || (score == best.2 && loss < best_loss);
        let averaged = cfg.average_epochs > 0 && epoch + cfg.average_epochs > cfg.epochs;
        if averaged {
            match &mut sum {
                None => sum = Some((w.clone(), 1)),
                Some((s, n)) => {
                    add_weights(s, &w);
                    *n += 1;
                }
            }
        }
        if improved {
            best = (w, epoch, score);
            best_loss = loss;
        }
        history.push(report);
        if cfg.patience > 0 && epoch - best.1 >= cfg.patience {
            break;
        }
    }
    let mut average = None;
    if let Some((mut mean, n)) = sum {
        scale_weights(&mut mean, 1.0 / n as f32);
        let last = history.len();
        // without a validation set the average is what was asked for
        let (accuracy, chosen) = if val.is_empty() {
            (f64::NAN, true)
        } else {
            let (loss, accuracy, _) = fitter.evaluate(&mean, val)?;
            (accuracy, accuracy > best.2 || (accuracy == best.2 && loss < best_loss))
        };
        average = Some((accuracy, chosen));
        if chosen {
            best = (mean, last, accuracy);
        }
    }
    // without a validation set there is no validation accuracy (the score was the epoch)
    let best_val_accuracy = if val.is_empty() { f64::NAN } else { best.2 };
    Ok(Outcome { weights: best.0, best_epoch: best.1, best_val_accuracy, average, history })
}

/// A layer's tensors: the weight, then the bias and recurrent tensors it has.
fn tensors_mut(l: &mut LayerWeights) -> impl Iterator<Item = &mut Vec<f32>> {
    std::iter::once(&mut l.weight).chain([&mut l.bias, &mut l.recurrent, &mut l.recurrent_bias].into_iter().flatten())
}

fn tensors(l: &LayerWeights) -> impl Iterator<Item = &Vec<f32>> {
    std::iter::once(&l.weight).chain([&l.bias, &l.recurrent, &l.recurrent_bias].into_iter().flatten())
}

/// `sum += w`, tensor by tensor (both of one spec).
fn add_weights(sum: &mut [LayerWeights], w: &[LayerWeights]) {
    for (s, w) in sum.iter_mut().zip(w) {
        for (a, b) in tensors_mut(s).zip(tensors(w)) {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
    }
}

fn scale_weights(w: &mut [LayerWeights], k: f32) {
    for t in w.iter_mut().flat_map(tensors_mut) {
        t.iter_mut().for_each(|x| *x *= k);
    }
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// A class balance ([`TrainConfig::class_balance`]) lies in [0, 1].
pub fn check_class_balance(balance: f64) -> snn::Result<()> {
    if (0.0..=1.0).contains(&balance) {
        Ok(())
    } else {
        Err(snn::Error::input(format!("class balance {balance} must lie in [0, 1]")))
    }
}

/// Checks a loss-spike guard ([`TrainConfig::loss_spike_guard`]): 0 (off) or a factor above 1
/// (at 1 or below every epoch not the best so far would be undone).
pub fn check_loss_spike_guard(factor: f64) -> snn::Result<()> {
    if factor == 0.0 || factor > 1.0 {
        Ok(())
    } else {
        Err(snn::Error::input(format!("loss-spike guard {factor}: 0 (off) or a factor above 1")))
    }
}

/// Class-balanced sampling's state ([`TrainConfig::class_balance`]): each class's share of an
/// epoch and its samples' indices, drawn in shuffled turns that carry over from epoch to epoch.
#[derive(Debug, Clone)]
pub struct ClassTurns {
    /// Draws per epoch of each class (summing to the training set's size).
    pub draws: Vec<usize>,
    pools: Vec<Vec<usize>>,
    /// How far each class's current turn has been drawn.
    next: Vec<usize>,
}

impl ClassTurns {
    /// The turns for samples labelled `labels` over `classes` classes at `balance` (None at 0:
    /// every sample once an epoch). Draws are `n * n_c^(1 - balance) / sum`, rounded by largest
    /// remainder (ties to the lower class) so that they sum to `n`; a class with samples draws
    /// at least one.
    pub fn new(labels: &[usize], classes: usize, balance: f64) -> Option<ClassTurns> {
        if balance == 0.0 || labels.is_empty() {
            return None;
        }
        let mut pools = vec![Vec::new(); classes.max(labels.iter().max().map_or(0, |&m| m + 1))];
        for (i, &l) in labels.iter().enumerate() {
            pools[l].push(i);
        }
        let weight: Vec<f64> =
            pools.iter().map(|p| if p.is_empty() { 0.0 } else { (p.len() as f64).powf(1.0 - balance) }).collect();
        let total: f64 = weight.iter().sum();
        let n = labels.len();
        let exact: Vec<f64> = weight.iter().map(|w| n as f64 * w / total).collect();
        let mut draws: Vec<usize> = exact
            .iter()
            .zip(&pools)
            .map(|(&e, p)| if p.is_empty() { 0 } else { (e.floor() as usize).max(1) })
            .collect();
        // largest remainders first, until the draws sum to n (or, where the floor of one took
        // some, the largest shares give one back)
        let mut by_remainder: Vec<usize> = (0..pools.len()).filter(|&c| !pools[c].is_empty()).collect();
        by_remainder
            .sort_by(|&a, &b| (exact[b] - exact[b].floor()).total_cmp(&(exact[a] - exact[a].floor())).then(a.cmp(&b)));
        let mut k = 0;
        while draws.iter().sum::<usize>() < n {
            draws[by_remainder[k % by_remainder.len()]] += 1;
            k += 1;
        }
        while draws.iter().sum::<usize>() > n {
            let c = (0..draws.len()).max_by_key(|&c| (draws[c], std::cmp::Reverse(c))).expect("a class");
            draws[c] -= 1;
        }
        let next = pools.iter().map(Vec::len).collect();
        Some(ClassTurns { draws, pools, next })
    }
}

/// The next epoch's sample order into `order`: every sample once, shuffled by `rng` (no turns),
/// or each class's draws taken from its turns, the whole shuffled.
pub fn epoch_order(order: &mut Vec<usize>, turns: Option<&mut ClassTurns>, rng: &mut ChaCha8Rng) {
    let Some(t) = turns else {
        order.shuffle(rng);
        return;
    };
    order.clear();
    for c in 0..t.pools.len() {
        for _ in 0..t.draws[c] {
            if t.next[c] == t.pools[c].len() {
                t.pools[c].shuffle(rng);
                t.next[c] = 0;
            }
            order.push(t.pools[c][t.next[c]]);
            t.next[c] += 1;
        }
    }
    order.shuffle(rng);
}

#[cfg(test)]
mod tests {
    use super::*;
    use encoders::spike_train::SpikeTrain;

    /// A fitter whose loss is scripted per step and whose one weight counts its steps.
    struct Scripted {
        losses: Vec<f64>,
        w: f32,
        lrs: Vec<f64>,
        restored: Vec<f32>,
    }

    impl Fitter for Scripted {
        fn step(&mut self, _: &SpikeSet, _: &[usize], lr: f64, _: &mut ChaCha8Rng) -> snn::Result<(f64, usize)> {
            self.lrs.push(lr);
            self.w += 1.0;
            Ok((self.losses[self.lrs.len() - 1], 0))
        }
        fn weights(&self) -> snn::Result<Vec<LayerWeights>> {
            Ok(vec![LayerWeights { weight: vec![self.w], bias: None, recurrent: None, recurrent_bias: None }])
        }
        fn evaluate(&self, _: &[LayerWeights], _: &SpikeSet) -> snn::Result<(f64, f64, Vec<f64>)> {
            Ok((0.0, 0.0, Vec::new()))
        }
        fn restore(&mut self, weights: &[LayerWeights]) -> snn::Result<()> {
            self.w = weights[0].weight[0];
            self.restored.push(self.w);
            Ok(())
        }
    }

    #[test]
    fn the_loss_spike_guard_undoes_a_jump_and_halves_the_rate_and_leaves_other_runs_alone() {
        let set = SpikeSet {
            n_inputs: 1,
            steps: 1,
            dt_us: 1_000,
            classes: vec!["a".into()],
            trains: vec![SpikeTrain {
                t_start_us: 0,
                dt_us: 1_000,
                n_inputs: 1,
                offsets: vec![0, 0],
                inputs: vec![],
                counts: vec![],
            }],
            labels: vec![0],
            dropped_events: 0,
        };
        // one sample, one step an epoch: the epoch's loss is the script's
        let losses = vec![2.0, 1.0, 0.8, 3.0, 0.7, 0.6];
        let run = |guard: f64| {
            let cfg = TrainConfig { epochs: 6, lr: 1e-3, loss_spike_guard: guard, ..TrainConfig::default() };
            let mut f = Scripted { losses: losses.clone(), w: 0.0, lrs: Vec::new(), restored: Vec::new() };
            let init = f.weights().unwrap();
            let out = fit(
                &mut f,
                &init,
                &set,
                &SpikeSet { trains: Vec::new(), labels: Vec::new(), ..set.clone() },
                &cfg,
                &mut Silent,
            )
            .unwrap();
            (out, f, cfg)
        };
        let (out, f, cfg) = run(2.0);
        // epoch 4 (3.0 > 2 x 0.8) is undone: back to epoch 3's weight, half the rate from epoch 5
        assert_eq!(f.restored, [3.0]);
        assert_eq!(out.history.iter().map(|r| r.undone).collect::<Vec<_>>(), [false, false, false, true, false, false]);
        assert_eq!(f.lrs[3], cfg.lr_at(4));
        assert_eq!((f.lrs[4], f.lrs[5]), (cfg.lr_at(5) * 0.5, cfg.lr_at(6) * 0.5));
        assert_eq!(out.weights[0].weight, [5.0], "the last epoch's weights, after the undone one");
        // without the guard, or with one the run never reaches, nothing changes
        for guard in [0.0, 4.0] {
            let (out, f, cfg) = run(guard);
            assert!(f.restored.is_empty() && out.history.iter().all(|r| !r.undone), "{guard}");
            assert_eq!(f.lrs, (1..=6).map(|e| cfg.lr_at(e)).collect::<Vec<_>>());
            assert_eq!(out.weights[0].weight, [6.0]);
        }
        assert!(check_loss_spike_guard(1.0).is_err() && check_loss_spike_guard(-2.0).is_err());
        assert!(check_loss_spike_guard(0.0).is_ok() && check_loss_spike_guard(1.5).is_ok());
    }

    #[test]
    fn the_warm_up_ramps_the_first_steps_and_then_leaves_the_schedule() {
        let cfg = TrainConfig { lr: 1e-3, warmup_steps: 4, ..TrainConfig::default() };
        let ramp: Vec<f64> = (1..=6).map(|k| cfg.warmed_up(cfg.lr_at(1), k)).collect();
        let want = [0.25e-3, 0.5e-3, 0.75e-3, 1e-3, 1e-3, 1e-3];
        assert!(ramp.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12), "{ramp:?}");
        let off = TrainConfig { warmup_steps: 0, ..cfg.clone() };
        assert_eq!(off.warmed_up(0.5, 1), 0.5, "no warm-up");
    }

    #[test]
    fn event_jitter_moves_each_event_within_its_bound_and_keeps_them_all() {
        // 50 events on input 1 at step 10 of 20, steps of 1 ms, jitter +- 2 ms
        let mut offsets = vec![0u32; 11];
        offsets.extend(std::iter::repeat_n(1u32, 10));
        let train = SpikeTrain { t_start_us: 0, dt_us: 1_000, n_inputs: 3, offsets, inputs: vec![1], counts: vec![50] };
        let set = SpikeSet {
            n_inputs: 3,
            steps: 20,
            dt_us: 1_000,
            classes: vec!["a".into()],
            trains: vec![train],
            labels: vec![0],
            dropped_events: 0,
        };
        let augment = Augment { event_jitter_us: 2_000, ..Augment::default() };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let steps = batch_input_augmented(&set, &[0], &Device::flex(), Some((&augment, &mut rng)));
        let per_step: Vec<Vec<f32>> =
            steps.iter().map(|t| t.to_data().convert::<f32>().try_to_vec::<f32>().unwrap()).collect();
        let on_input_1: Vec<f32> = per_step.iter().map(|s| s[1]).collect();
        assert_eq!(on_input_1.iter().sum::<f32>(), 50.0, "no event lost: {on_input_1:?}");
        assert!(per_step.iter().all(|s| s[0] == 0.0 && s[2] == 0.0), "events stay on their input");
        for (k, &c) in on_input_1.iter().enumerate() {
            assert!(c == 0.0 || (8..=12).contains(&k), "step {k} is beyond the jitter: {on_input_1:?}");
        }
        assert!(on_input_1.iter().filter(|&&c| c > 0.0).count() >= 4, "events spread: {on_input_1:?}");
        let plain = batch_input(&set, &[0], &Device::flex());
        assert_eq!(plain[10].to_data().convert::<f32>().try_to_vec::<f32>().unwrap(), vec![0.0, 50.0, 0.0]);
    }

    /// Square-root sampling of 90 A, 9 B and 1 C: 100 draws an epoch shared as n^0.5 (9.49 : 3 : 1,
    /// so 70.3, 22.2 and 7.4, rounded by largest remainder to 70, 22 and 8), each class's samples
    /// all drawn before any twice; at 0 every sample once.
    #[test]
    fn class_balance_shares_the_epoch_and_cycles_each_class() {
        let labels: Vec<usize> = [vec![0; 90], vec![1; 9], vec![2; 1]].concat();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut order: Vec<usize> = (0..100).collect();
        epoch_order(&mut order, None, &mut rng);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..100).collect::<Vec<_>>(), "no turns: a permutation");
        assert!(ClassTurns::new(&labels, 3, 0.0).is_none());

        let mut t = ClassTurns::new(&labels, 3, 0.5).unwrap();
        assert_eq!(t.draws, vec![70, 22, 8]);
        let w = [90f64.sqrt(), 3.0, 1.0];
        let exact: Vec<f64> = w.iter().map(|x| 100.0 * x / w.iter().sum::<f64>()).collect();
        assert_eq!(t.draws.iter().sum::<usize>(), 100);
        for (d, e) in t.draws.iter().zip(&exact) {
            assert!((*d as f64 - e).abs() < 1.0, "{:?} against {exact:?}", t.draws);
        }
        // B's nine samples: its draws over two epochs hold every one of them at least
        // floor(draws / 9) times and none more than once beyond that
        let mut count = [0usize; 100];
        for _ in 0..2 {
            epoch_order(&mut order, Some(&mut t), &mut rng);
            assert_eq!(order.len(), 100);
            order.iter().for_each(|&i| count[i] += 1);
        }
        let b = &count[90..99];
        let (lo, hi) = (b.iter().min().unwrap(), b.iter().max().unwrap());
        assert!(hi - lo <= 1 && b.iter().sum::<usize>() == 2 * t.draws[1], "{b:?}");
        assert_eq!(count[99], 2 * t.draws[2]);
        // fully balanced: every class alike
        let t = ClassTurns::new(&labels, 3, 1.0).unwrap();
        assert_eq!(t.draws, vec![34, 33, 33]);
    }
}
