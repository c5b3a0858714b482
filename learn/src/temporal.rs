//! Conventional (non-spiking) networks over a tactile sample's events binned in time: the
//! baselines an SNN is compared with on the same data. A GRU or an LSTM reads the bins one after
//! the other and classifies from its last hidden state; a temporal CNN (dilated 1-D
//! convolutions, ReLU, residual from the second block on) classifies from the mean and the
//! maximum of its last block over time. Input: per bin and input (channel and polarity),
//! `ln(1 + events)`. Trained with burn's autodiff (CPU `flex`): Adam, a cosine learning rate,
//! seeded initialisation and shuffling, the training augmentation of the SNN trainers
//! ([`crate::train::Augment`]), the best validation epoch kept.

use crate::data::SpikeSet;
use crate::train::{EpochReport, Observer, TrainConfig};
use burn::module::Module;
use burn::nn::conv::{Conv1d, Conv1dConfig};
use burn::nn::gru::{Gru, GruConfig};
use burn::nn::loss::CrossEntropyLossConfig;
use burn::nn::lstm::{Lstm, LstmConfig};
use burn::nn::{Dropout, DropoutConfig, Linear, LinearConfig, PaddingConfig1d};
use burn::optim::grad_clipping::GradientClippingConfig;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Int, Tensor, TensorData};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Which network.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TemporalKind {
    Gru,
    Lstm,
    /// Dilated 1-D convolutions over time (a temporal convolutional network).
    Tcn,
}

impl TemporalKind {
    pub fn name(self) -> &'static str {
        match self {
            TemporalKind::Gru => "GRU",
            TemporalKind::Lstm => "LSTM",
            TemporalKind::Tcn => "temporal CNN",
        }
    }
}

/// A network and its input binning.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TemporalConfig {
    pub kind: TemporalKind,
    /// Hidden units (recurrent) or channels (each convolutional block).
    pub hidden: usize,
    /// Recurrent layers are one; convolutional blocks, dilated 1, 2, 4, ...
    pub blocks: usize,
    /// Convolution kernel width, in bins.
    pub kernel: usize,
    /// The data's steps summed into one bin.
    pub steps_per_bin: usize,
    /// Dropout before the classifier (and between convolutional blocks).
    pub dropout: f64,
}

impl TemporalConfig {
    /// Bins of a sample of `steps` steps.
    pub fn bins(&self, steps: usize) -> usize {
        steps.div_ceil(self.steps_per_bin.max(1)).max(1)
    }

    /// Trainable parameters for `n_inputs` inputs and `classes` classes.
    pub fn parameters(&self, n_inputs: usize, classes: usize) -> usize {
        let (n, h) = (n_inputs, self.hidden);
        match self.kind {
            // burn's gates each have an input and a hidden linear map, both with bias
            TemporalKind::Gru => 3 * (n * h + h + h * h + h) + h * classes + classes,
            TemporalKind::Lstm => 4 * (n * h + h + h * h + h) + h * classes + classes,
            TemporalKind::Tcn => {
                let k = self.kernel;
                (n * h * k + h) + (self.blocks.max(1) - 1) * (h * h * k + h) + 2 * h * classes + classes
            }
        }
    }

    /// Multiply-accumulates per sample of `steps` steps (weights times inputs; gates'
    /// nonlinearities and the element-wise products not counted).
    pub fn macs_per_sample(&self, n_inputs: usize, classes: usize, steps: usize) -> u64 {
        let t = self.bins(steps) as u64;
        let (n, h, c) = (n_inputs as u64, self.hidden as u64, classes as u64);
        match self.kind {
            TemporalKind::Gru => t * 3 * (n * h + h * h) + h * c,
            TemporalKind::Lstm => t * 4 * (n * h + h * h) + h * c,
            TemporalKind::Tcn => {
                let k = self.kernel as u64;
                t * (n * h * k + (self.blocks.max(1) as u64 - 1) * h * h * k) + 2 * h * c
            }
        }
    }

    /// Short text: `GRU 128, 5 steps a bin`.
    pub fn describe(&self) -> String {
        let net = match self.kind {
            TemporalKind::Tcn => format!("{} {}x{} k{}", self.kind.name(), self.blocks, self.hidden, self.kernel),
            _ => format!("{} {}", self.kind.name(), self.hidden),
        };
        format!("{net}, {} steps a bin, dropout {}", self.steps_per_bin, self.dropout)
    }

    fn init(&self, n_inputs: usize, classes: usize, device: &Device) -> TemporalNet {
        let h = self.hidden.max(1);
        let (gru, lstm, convs) = match self.kind {
            TemporalKind::Gru => (Some(GruConfig::new(n_inputs, h, true).init(device)), None, Vec::new()),
            TemporalKind::Lstm => (None, Some(LstmConfig::new(n_inputs, h, true).init(device)), Vec::new()),
            TemporalKind::Tcn => {
                let k = self.kernel.max(1);
                let convs = (0..self.blocks.max(1))
                    .map(|b| {
                        let dilation = 1usize << b;
                        let pad = dilation * (k - 1);
                        Conv1dConfig::new(if b == 0 { n_inputs } else { h }, h, k)
                            .with_dilation(dilation)
                            .with_padding(PaddingConfig1d::Explicit(pad / 2, pad - pad / 2))
                            .init(device)
                    })
                    .collect();
                (None, None, convs)
            }
        };
        let features = if self.kind == TemporalKind::Tcn { 2 * h } else { h };
        TemporalNet {
            gru,
            lstm,
            convs,
            dropout: DropoutConfig::new(self.dropout).init(),
            head: LinearConfig::new(features, classes).init(device),
        }
    }
}

/// The network's modules (which are present says which kind it is).
#[derive(Module, Debug)]
pub struct TemporalNet {
    gru: Option<Gru>,
    lstm: Option<Lstm>,
    convs: Vec<Conv1d>,
    dropout: Dropout,
    head: Linear,
}

impl TemporalNet {
    /// Logits `[batch, classes]` of bins `[batch, bins, inputs]`.
    pub fn forward(&self, x: Tensor<3>) -> Tensor<2> {
        let [b, t, _] = x.dims();
        let features = if let Some(gru) = &self.gru {
            let h = gru.forward(x, None);
            let d = h.dims()[2];
            h.slice([0..b, t - 1..t, 0..d]).reshape([b, d])
        } else if let Some(lstm) = &self.lstm {
            let (_, state) = lstm.forward(x, None);
            state.hidden
        } else {
            let mut y = x.swap_dims(1, 2);
            for (i, conv) in self.convs.iter().enumerate() {
                let z = relu(conv.forward(y.clone()));
                y = if i == 0 { z } else { self.dropout.forward(z) + y };
            }
            let mean = y.clone().mean_dim(2).squeeze_dim::<2>(2);
            let max = y.max_dim(2).squeeze_dim::<2>(2);
            Tensor::cat(vec![mean, max], 1)
        };
        self.head.forward(self.dropout.forward(features))
    }
}

/// One sample's (augmented) `(step, input, count)` entries as `bins` rows of `ln(1 + events)`
/// per input.
fn binned(entries: &crate::sparse::Entries, n_inputs: usize, steps_per_bin: usize, bins: usize) -> Vec<f32> {
    let mut out = vec![0f32; bins * n_inputs];
    for &(t, i, c) in entries {
        let b = (t as usize / steps_per_bin.max(1)).min(bins - 1);
        out[b * n_inputs + i as usize] += c;
    }
    for v in &mut out {
        *v = v.ln_1p();
    }
    out
}

fn batch(
    set: &SpikeSet,
    idx: &[usize],
    cfg: &TemporalConfig,
    device: &Device,
    augment: Option<(&crate::train::Augment, &mut rand_chacha::ChaCha8Rng)>,
) -> Tensor<3> {
    let bins = cfg.bins(set.steps);
    let mut data = Vec::with_capacity(idx.len() * bins * set.n_inputs);
    let mut augment = augment;
    for &s in idx {
        let entries = crate::train::sample_entries(set, s, augment.as_mut().map(|(a, rng)| (*a, &mut **rng)));
        data.extend(binned(&entries, set.n_inputs, cfg.steps_per_bin, bins));
    }
    Tensor::<3>::from_data(TensorData::new(data, [idx.len(), bins, set.n_inputs]), device)
}

fn targets(set: &SpikeSet, idx: &[usize], device: &Device) -> Tensor<1, Int> {
    let t: Vec<i64> = idx.iter().map(|&i| set.labels[i] as i64).collect();
    Tensor::<1, Int>::from_data(TensorData::new(t, [idx.len()]), device)
}

/// A trained network with its configuration.
#[derive(Debug, Clone)]
pub struct TrainedTemporal {
    pub config: TemporalConfig,
    pub net: TemporalNet,
    pub best_epoch: usize,
    pub best_val_accuracy: f64,
    pub history: Vec<EpochReport>,
}

impl TrainedTemporal {
    /// Mean loss, accuracy and the predictions on `set`.
    pub fn evaluate(&self, set: &SpikeSet) -> (f64, f64, Vec<usize>) {
        evaluate(&self.net, &self.config, set)
    }
}

/// Mean loss, accuracy and predictions of `net` (no autodiff) on `set`, in batches of 64.
pub fn evaluate(net: &TemporalNet, cfg: &TemporalConfig, set: &SpikeSet) -> (f64, f64, Vec<usize>) {
    let device = Device::flex();
    let loss_fn = CrossEntropyLossConfig::new().init(&device);
    let idx: Vec<usize> = (0..set.len()).collect();
    let (mut loss, mut preds) = (0.0, Vec::with_capacity(set.len()));
    for chunk in idx.chunks(64) {
        let logits = net.forward(batch(set, chunk, cfg, &device, None));
        preds.extend(crate::predicted_classes(&logits));
        loss += loss_fn.forward(logits, targets(set, chunk, &device)).into_scalar::<f32>() as f64 * chunk.len() as f64;
    }
    let n = set.len().max(1) as f64;
    let hits = snn::scoring::hits(preds.iter().copied(), set.labels.iter().copied());
    (loss / n, hits as f64 / n, preds)
}

/// Trains `cfg` on `train_set`, choosing the epoch on `val` (without one, the last epoch):
/// Adam at `tc.lr` on a cosine (`tc.lr_at`), `tc.batch_size`, `tc.clip_norm` (0: none),
/// `tc.weight_decay` (coupled L2; 0: none), `tc.augment`, `tc.patience` (0: all epochs). The same
/// `tc.seed` gives the same weights (burn's dropout draws from the device's process-wide
/// generator: run trainings one after the other).
pub fn train(
    cfg: &TemporalConfig,
    train_set: &SpikeSet,
    val: Option<&SpikeSet>,
    tc: &TrainConfig,
    observer: &mut dyn Observer,
) -> TrainedTemporal {
    let device = Device::flex().autodiff();
    device.seed(tc.seed);
    let classes = train_set.classes.len().max(train_set.labels.iter().map(|&l| l + 1).max().unwrap_or(1));
    let mut net = cfg.init(train_set.n_inputs, classes, &device);
    let mut adam = AdamConfig::new();
    if tc.clip_norm > 0.0 {
        adam = adam.with_grad_clipping(Some(GradientClippingConfig::Norm(tc.clip_norm as f32)));
    }
    if tc.weight_decay > 0.0 {
        adam = adam.with_weight_decay(Some(burn::optim::decay::WeightDecayConfig::new(tc.weight_decay as f32)));
    }
    let mut optim = adam.init();
    let loss_fn = CrossEntropyLossConfig::new().init(&device);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(tc.seed);
    let mut order: Vec<usize> = (0..train_set.len()).collect();
    let mut best: (Option<TemporalNet>, usize, f64) = (None, 0, -1.0);
    let mut history = Vec::new();
    let augment = (tc.augment != crate::train::Augment::default()).then_some(tc.augment);
    let mut step = 0usize;
    for epoch in 1..=tc.epochs.max(1) {
        let start = Instant::now();
        let lr = tc.lr_at(epoch);
        order.shuffle(&mut rng);
        let batches: Vec<&[usize]> = order.chunks(tc.batch_size.max(1)).collect();
        observer.epoch_begin(epoch, batches.len());
        let (mut loss_sum, mut hits) = (0.0, 0usize);
        for idx in batches {
            step += 1;
            let x = batch(train_set, idx, cfg, &device, augment.as_ref().map(|a| (a, &mut rng)));
            let logits = net.forward(x);
            let h = snn::scoring::hits(crate::predicted_classes(&logits), idx.iter().map(|&i| train_set.labels[i]));
            let loss = loss_fn.forward(logits, targets(train_set, idx, &device));
            let l = loss.clone().into_scalar::<f32>() as f64;
            let grads = GradientsParams::from_grads(loss.backward(), &net);
            net = optim.step(tc.warmed_up(lr, step), net, grads);
            loss_sum += l * idx.len() as f64;
            hits += h;
            observer.batch(l, h as f64 / idx.len() as f64);
        }
        let inference = net.valid();
        let (val_loss, val_accuracy) = match val {
            Some(v) if !v.is_empty() => {
                let (l, a, _) = evaluate(&inference, cfg, v);
                (l, a)
            }
            _ => (f64::NAN, f64::NAN),
        };
        let report =
            EpochReport::without_spikes(epoch, lr, (loss_sum, hits, train_set.len()), (val_loss, val_accuracy), start);
        observer.epoch_end(&report);
        history.push(report);
        // without validation the last epoch; ties go to the earlier epoch
        let score = if val_accuracy.is_nan() { epoch as f64 } else { val_accuracy };
        if score > best.2 {
            best = (Some(inference), epoch, score);
        }
        if tc.patience > 0 && epoch >= best.1 + tc.patience {
            break;
        }
    }
    let (net, best_epoch, score) = best;
    TrainedTemporal {
        config: *cfg,
        net: net.expect("at least one epoch ran"),
        best_epoch,
        best_val_accuracy: if val.is_some_and(|v| !v.is_empty()) { score } else { f64::NAN },
        history,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_counts_follow_the_shapes() {
        let gru =
            TemporalConfig { kind: TemporalKind::Gru, hidden: 4, blocks: 1, kernel: 1, steps_per_bin: 5, dropout: 0.0 };
        // 12 steps -> 3 bins; 3 gates x (2 x 4 + 4 x 4) per bin, then 4 x 3 for the head
        assert_eq!(gru.macs_per_sample(2, 3, 12), 3 * 3 * (8 + 16) + 12);
        let device = Device::flex();
        let counted = |cfg: &TemporalConfig| cfg.init(2, 3, &device).num_params();
        assert_eq!(gru.parameters(2, 3), counted(&gru));
        let lstm = TemporalConfig { kind: TemporalKind::Lstm, ..gru };
        assert_eq!(lstm.parameters(2, 3), counted(&lstm));
        let tcn = TemporalConfig { kind: TemporalKind::Tcn, blocks: 3, kernel: 3, ..gru };
        assert_eq!(tcn.parameters(2, 3), counted(&tcn));
        assert_eq!(tcn.macs_per_sample(2, 3, 12), 3 * (2 * 4 * 3 + 2 * 4 * 4 * 3) + 2 * 4 * 3);
    }
}
