//! The SNN's trainer that works where the spikes are: backpropagation through time with surrogate
//! gradients, exact or truncated, without dense tensors. It runs the discrete update of
//! [`snn::neuron::NeuronParams::step`] (the engine's in stepped mode, and the burn twin's,
//! [`crate::snn::SnnTwin`], whose gradients it reproduces; see the tests).
//!
//! Forward, each layer takes a list of events per step (input counts, the layer below's spikes)
//! and adds each one's fan-out (its weight row, or the convolution targets of its pixel) into the
//! layer's currents; the membranes are then stepped densely. Per step it keeps only what BPTT
//! needs: the spikes, and the neurons whose surrogate derivative is not zero with its value (when
//! all are kept, the exact gradient, every neuron's derivative in a dense array instead).
//!
//! Backward, layer by layer from the top, time reversed:
//!
//! ```text
//! g_v'[t] = sum_{kept n at t} (g_out[t] + g_rec[t]) sigma'  +  (1 - z[t] if reset to zero) beta g_v'[t+1]
//! g_i[t]  = g_v'[t] + alpha g_i[t+1]                                CubaLIF (g_u = g_i; else g_u = g_v')
//! dW     += x[t] (x) g_u[t]       over the events x of the layer's input at t: the forward's fan-out
//! g_x[t]  = W^T g_u[t]            only where the layer below keeps a surrogate at t
//! ```
//!
//! The reset is detached, as in the twin. With the truncation off (`cutoff` 0) every neuron's
//! surrogate is kept and the gradient is exact. With `cutoff` c > 0 the surrogate derivative is
//! taken as zero where it is below c times its peak (Perez-Nieves and Goodman, "Sparse spiking
//! gradient descent", NeurIPS 2021): the kept neurons are those near threshold, and the gradient
//! sent down a layer, the costly product, is computed for them alone.
//!
//! Samples of a batch run in parallel (rayon), in fixed chunks summed in a fixed order, so the
//! same seed gives the same weights whatever the number of threads.
//!
//! Internally, 3-d activations are channel-last (`[y][x][c]`), so that a pixel's fan-out over
//! channels is contiguous; weights are laid out for fan-out (`[in][out]`, convolution
//! `[in_c][ky][kx][out_c]`). [`SparseSnn::params`] and [`SparseSnn::weights`] convert from and to
//! the engine's layouts.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
#[cfg(target_arch = "x86_64")]
use snn::engine::PACKED_LANES;
use snn::engine::{conv_positions, pool_targets};
use snn::model_file::Readout;
use snn::network::PoolKind;
use snn::neuron::{NeuronKind, NeuronParams, Reset, Surrogate};
use snn::spec::{LayerWeights, NetworkSpec, OpSpec};

mod adam;
mod backward;
mod batch;
pub mod chip;
mod forward;
mod kernels;
mod loss;

pub use adam::Adam;
use kernels::*;
pub use loss::{Distill, cross_entropy, distillation, softmax_at};

/// One sample's input as `(step, input, count)` entries, in any order.
pub type Entries = Vec<(u32, u32, f32)>;

/// Events of one sample, step by step: step `t`'s are `idx[start[t]..start[t + 1]]` with their
/// values.
#[derive(Debug, Clone, PartialEq)]
pub struct StepEvents {
    start: Vec<u32>,
    idx: Vec<u32>,
    val: Vec<f32>,
}

impl Default for StepEvents {
    fn default() -> Self {
        Self { start: vec![0], idx: Vec::new(), val: Vec::new() }
    }
}

impl StepEvents {
    /// `(step, index, value)` entries over `steps` steps (entries at later steps are left out;
    /// repeated indices add up).
    pub fn from_entries(steps: usize, entries: &mut [(u32, u32, f32)]) -> Self {
        entries.sort_by_key(|e| (e.0, e.1));
        let mut ev = StepEvents::default();
        let mut it = entries.iter().peekable();
        for t in 0..steps as u32 {
            while let Some(&&(s, i, v)) = it.peek() {
                if s != t {
                    break;
                }
                ev.push(i, v);
                it.next();
            }
            ev.end_step();
        }
        ev
    }

    #[inline]
    fn push(&mut self, i: u32, v: f32) {
        self.idx.push(i);
        self.val.push(v);
    }

    #[inline]
    fn end_step(&mut self) {
        self.start.push(self.idx.len() as u32);
    }

    pub fn steps(&self) -> usize {
        self.start.len() - 1
    }

    /// Step `t`'s indices and values.
    #[inline]
    pub fn at(&self, t: usize) -> (&[u32], &[f32]) {
        let (a, b) = (self.start[t] as usize, self.start[t + 1] as usize);
        (&self.idx[a..b], &self.val[a..b])
    }

    /// No step, no event (the buffers kept).
    fn clear(&mut self) {
        self.start.clear();
        self.start.push(0);
        self.idx.clear();
        self.val.clear();
    }

    /// Events in all.
    pub fn len(&self) -> usize {
        self.idx.len()
    }

    pub fn is_empty(&self) -> bool {
        self.idx.is_empty()
    }

    /// The same events with each index mapped by `f`.
    fn map_indices(mut self, f: impl Fn(u32) -> u32) -> Self {
        self.idx.iter_mut().for_each(|i| *i = f(*i));
        self
    }
}

/// How a layer's activations are laid out: flat, or channel-last over `plane` pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Layout {
    Flat,
    Hwc { c: usize, plane: usize },
}

impl Layout {
    fn of(shape: &[usize]) -> Layout {
        match shape {
            [c, h, w] => Layout::Hwc { c: *c, plane: h * w },
            _ => Layout::Flat,
        }
    }

    /// The internal index of C-order index `i`.
    #[inline]
    fn internal(self, i: usize) -> usize {
        match self {
            Layout::Flat => i,
            Layout::Hwc { c, plane } => (i % plane) * c + i / plane,
        }
    }
}

/// A layer's linear operation with its fan-out maps.
#[derive(Debug, Clone)]
enum Kernel {
    /// Weights `[in][out]`.
    Dense,
    /// Weights `[in_c][k][out_c]`; pixel `p`'s targets are `targets[offsets[p]..offsets[p + 1]]`,
    /// each (output pixel, kernel position).
    Conv { ic: usize, oc: usize, kk: usize, offsets: Vec<u32>, targets: Vec<(u32, u32)> },
    /// Pixel `p`'s output pixels are `targets[offsets[p]..offsets[p + 1]]`.
    Pool { c: usize, weight: f32, offsets: Vec<u32>, targets: Vec<u32> },
}

#[derive(Debug, Clone)]
struct Plan {
    kernel: Kernel,
    n_out: usize,
    output: Layout,
    neurons: Option<NeuronParams>,
    /// Bias entries (0: none); output `o`'s is `o % bias_len` (channel-last convolutions).
    bias_len: usize,
    recurrent: bool,
}

/// A layer's trainable tensors in fan-out layouts; empty where the layer has none. Gradients and
/// optimiser moments have the same form.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Tensors {
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
    pub recurrent: Vec<f32>,
}

impl Tensors {
    fn zeros_like(&self) -> Tensors {
        Tensors {
            weight: vec![0.0; self.weight.len()],
            bias: vec![0.0; self.bias.len()],
            recurrent: vec![0.0; self.recurrent.len()],
        }
    }

    fn all(&self) -> [&Vec<f32>; 3] {
        [&self.weight, &self.bias, &self.recurrent]
    }

    fn all_mut(&mut self) -> [&mut Vec<f32>; 3] {
        [&mut self.weight, &mut self.bias, &mut self.recurrent]
    }
}

/// A network's trainable tensors (or their gradients).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Params {
    pub layers: Vec<Tensors>,
}

impl Params {
    pub fn zeros_like(&self) -> Params {
        Params { layers: self.layers.iter().map(Tensors::zeros_like).collect() }
    }

    /// Every tensor, layer by layer (weight, bias, recurrent; empty ones included).
    pub fn tensors(&self) -> impl Iterator<Item = &Vec<f32>> {
        self.layers.iter().flat_map(Tensors::all)
    }

    pub fn tensors_mut(&mut self) -> impl Iterator<Item = &mut Vec<f32>> {
        self.layers.iter_mut().flat_map(Tensors::all_mut)
    }

    fn add(&mut self, other: &Params) {
        for (a, b) in self.tensors_mut().zip(other.tensors()) {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
    }
}

/// What one sample's forward pass keeps of a layer.
#[derive(Debug, Clone, Default)]
struct LayerTape {
    /// What the next layer receives: spikes (times a dropout mask), or values.
    out: StepEvents,
    /// Spikes, for the reset and the recurrence.
    spikes: StepEvents,
    /// The neurons whose surrogate derivative is kept, with its value (empty steps when every
    /// neuron keeps it: see `surr_all`).
    surr: StepEvents,
    /// Every neuron's surrogate derivative, `n` a step, when all are kept (the exact gradient of
    /// the float forward): no index to store or read.
    surr_all: Vec<f32>,
    /// Leaky-integrator readout: each neuron's step of its highest membrane.
    argmax: Vec<u32>,
    n_spikes: usize,
}

/// The surrogate derivatives a layer keeps at a step.
enum Kept<'a> {
    /// Every neuron's, in order.
    All(&'a [f32]),
    /// These neurons', with their values.
    Listed(&'a [u32], &'a [f32]),
}

impl LayerTape {
    /// The surrogate derivatives kept at step `t` of a layer of `n` neurons.
    #[inline(always)]
    fn kept(&self, t: usize, n: usize) -> Kept<'_> {
        if self.surr_all.is_empty() {
            let (i, v) = self.surr.at(t);
            Kept::Listed(i, v)
        } else {
            Kept::All(&self.surr_all[t * n..][..n])
        }
    }

    /// Neuron-steps whose surrogate derivative is kept.
    fn n_kept(&self) -> usize {
        self.surr.len() + self.surr_all.len()
    }

    /// This tape emptied, its buffers kept for the next sample (a sample's tape is some MB: made
    /// anew each time, its pages would be faulted in again).
    fn cleared(mut self) -> LayerTape {
        for e in [&mut self.out, &mut self.spikes, &mut self.surr] {
            e.clear();
        }
        self.surr_all.clear();
        self.argmax.clear();
        self.n_spikes = 0;
        self
    }
}

/// One sample's forward pass.
#[derive(Debug, Clone)]
pub struct SampleOutput {
    /// Spike counts or max membranes, in class order.
    pub logits: Vec<f32>,
    /// Spikes of each spiking layer.
    pub spikes: Vec<usize>,
    tape: Vec<LayerTape>,
    /// The readout's highest membranes before the clamp at zero.
    v_max: Vec<f32>,
    /// Each layer's input arrives one step after the layer below sent it (a chip's forward,
    /// [`chip`]); the float forward passes it on within the step.
    delayed: bool,
}

/// A batch's gradient, loss and hits.
#[derive(Debug, Clone)]
pub struct BatchGradient {
    pub grads: Params,
    /// Summed over the batch (the gradient is of the mean).
    pub loss_sum: f64,
    pub hits: usize,
    /// Spikes of each spiking layer, summed over the batch.
    pub spikes: Vec<f64>,
    /// Neuron-steps whose surrogate derivative was kept (all of them when exact), over the batch.
    pub kept_surrogates: usize,
}

/// Forward and backward passes of a network, sparse.
#[derive(Debug, Clone)]
pub struct SparseSnn {
    pub spec: NetworkSpec,
    pub surrogate: Surrogate,
    pub readout: Readout,
    /// Backpropagate the readout's clamp at zero as it is instead of straight through (as
    /// [`crate::snn::SnnTwin::clamped_readout_gradient`]).
    pub clamped_readout_gradient: bool,
    /// Truncation: surrogate derivatives below this fraction of their peak count as zero (0: exact).
    cutoff: f32,
    /// `|v - v_th|` beyond which the surrogate is truncated (infinite when exact).
    x_cut: f32,
    input: Layout,
    plans: Vec<Plan>,
    /// Buffers kept from one batch to the next ([`Scratch`]).
    scratch: Scratch,
}

/// A worker's buffers (a sample's tape, the backward's step-by-step gradients) and the chunks'
/// gradient sums, kept from one batch to the next: some MB, which allocated anew for each batch
/// would have their pages faulted in and cleared again by the kernel (a fifth of the truncated
/// step's time on the peer network). Results do not depend on them. A clone starts empty.
#[derive(Debug, Default)]
struct Scratch {
    workers: std::sync::Mutex<Vec<KeptBuffers>>,
    grads: std::sync::Mutex<Vec<Params>>,
}

/// A worker's tape and its backward's step-by-step buffers, kept in [`Scratch`].
type KeptBuffers = (Vec<LayerTape>, Vec<Vec<f32>>);

impl Clone for Scratch {
    fn clone(&self) -> Scratch {
        Scratch::default()
    }
}

impl Scratch {
    /// Zeroed gradients shaped as `params`, from a kept buffer when one fits.
    fn zeros_like(&self, params: &Params) -> Params {
        let kept = self.grads.lock().unwrap_or_else(std::sync::PoisonError::into_inner).pop();
        match kept {
            Some(mut g) if g.tensors().map(Vec::len).eq(params.tensors().map(Vec::len)) => {
                g.tensors_mut().for_each(|t| t.fill(0.0));
                g
            }
            _ => params.zeros_like(),
        }
    }

    fn keep_grads(&self, g: Params) {
        self.grads.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(g);
    }
}

/// A worker's buffers taken from [`Scratch`] for one batch, given back when dropped.
struct WorkerBuffers<'a> {
    scratch: &'a Scratch,
    tape: Vec<LayerTape>,
    pool: Vec<Vec<f32>>,
}

impl<'a> WorkerBuffers<'a> {
    fn take(scratch: &'a Scratch) -> WorkerBuffers<'a> {
        let kept = scratch.workers.lock().unwrap_or_else(std::sync::PoisonError::into_inner).pop();
        let (tape, pool) = kept.unwrap_or_default();
        WorkerBuffers { scratch, tape, pool }
    }
}

impl Drop for WorkerBuffers<'_> {
    fn drop(&mut self) {
        let kept = (std::mem::take(&mut self.tape), std::mem::take(&mut self.pool));
        self.scratch.workers.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(kept);
    }
}

/// Whether both trainers can train `spec` read by `readout`: no recurrent biases, and an output
/// layer that fits the readout.
pub fn check_trainable(spec: &NetworkSpec, readout: Readout) -> snn::Result<()> {
    if let Some(k) = spec.layers.iter().position(|l| l.recurrent_bias) {
        return Err(snn::Error::layer(k, "recurrent biases are not trained here"));
    }
    let last = spec.layers.last().and_then(|l| l.neurons).map(|p| p.kind);
    match (readout, last) {
        (Readout::MaxMembrane, Some(NeuronKind::Li)) => Ok(()),
        (Readout::SpikeCount, Some(k)) if k != NeuronKind::Li => Ok(()),
        _ => Err(snn::Error::network(format!("readout {readout:?} does not fit an output layer of {last:?} neurons"))),
    }
}

/// The truncation `braille train` uses unless told: surrogate derivatives below 1% of their peak
/// count as zero.
pub const DEFAULT_CUTOFF: f32 = 0.01;

/// Samples per parallel chunk at most: chunks are summed in order, so results do not depend on
/// the thread count.
const CHUNKS: usize = 8;

impl SparseSnn {
    /// The trainer of `spec` with `surrogate` and `readout`, truncating surrogate derivatives
    /// below `cutoff` times their peak (0: exact).
    pub fn new(spec: NetworkSpec, surrogate: Surrogate, readout: Readout, cutoff: f32) -> snn::Result<SparseSnn> {
        let shapes = spec.shapes()?;
        if !(0.0..1.0).contains(&cutoff) {
            return Err(snn::Error::network(format!("gradient cutoff {cutoff} must lie in [0, 1)")));
        }
        check_trainable(&spec, readout)?;
        let input = Layout::of(&spec.input_shape);
        let mut plans = Vec::with_capacity(spec.layers.len());
        for (l, s) in spec.layers.iter().zip(&shapes) {
            let in_hw = || (s.input.len() == 3).then(|| [s.input[1], s.input[2]]);
            let out_hw = [s.output.get(1).copied().unwrap_or(1), s.output.get(2).copied().unwrap_or(1)];
            let kernel = match l.op {
                OpSpec::Dense { .. } => Kernel::Dense,
                OpSpec::Conv2d { out_channels, kernel, stride, padding } => {
                    let [h, w] = in_hw().ok_or_else(|| snn::Error::network("a convolution needs a 3-d input"))?;
                    let (mut offsets, mut targets) = (vec![0u32], Vec::new());
                    for y in 0..h {
                        for x in 0..w {
                            conv_positions(y, x, kernel, stride, padding, out_hw, |ky, kx, q| {
                                targets.push((q as u32, (ky * kernel[1] + kx) as u32));
                            });
                            offsets.push(targets.len() as u32);
                        }
                    }
                    Kernel::Conv { ic: s.input[0], oc: out_channels, kk: kernel[0] * kernel[1], offsets, targets }
                }
                OpSpec::Pool { kind, kernel, stride } => {
                    let [h, w] = in_hw().ok_or_else(|| snn::Error::network("a pooling needs a 3-d input"))?;
                    let (mut offsets, mut targets) = (vec![0u32], Vec::new());
                    for p in 0..h * w {
                        // channel 0's targets are the pixel's output pixels
                        pool_targets(p, [h, w], out_hw, kernel, stride, |q| targets.push(q as u32));
                        offsets.push(targets.len() as u32);
                    }
                    let weight = match kind {
                        PoolKind::Sum => 1.0,
                        PoolKind::Avg => 1.0 / (kernel[0] * kernel[1]) as f32,
                    };
                    Kernel::Pool { c: s.input[0], weight, offsets, targets }
                }
            };
            plans.push(Plan {
                kernel,
                n_out: s.output.iter().product(),
                output: Layout::of(&s.output),
                neurons: l.neurons,
                bias_len: s.bias.first().copied().unwrap_or(0),
                recurrent: l.recurrent,
            });
        }
        let x_cut = truncation_width(surrogate, cutoff);
        Ok(SparseSnn {
            spec,
            surrogate,
            readout,
            clamped_readout_gradient: false,
            cutoff,
            x_cut,
            input,
            plans,
            scratch: Scratch::default(),
        })
    }

    pub fn cutoff(&self) -> f32 {
        self.cutoff
    }

    pub fn n_outputs(&self) -> usize {
        self.plans.last().map_or(0, |p| p.n_out)
    }

    /// The layout of the layer below `k` (the input for `k` = 0).
    fn input_layout(&self, k: usize) -> Layout {
        if k == 0 { self.input } else { self.plans[k - 1].output }
    }

    /// `weights` (engine layouts) in fan-out layouts.
    pub fn params(&self, weights: &[LayerWeights]) -> snn::Result<Params> {
        // building checks every length against the spec
        self.spec.build(weights.to_vec())?;
        let shapes = self.spec.shapes()?;
        let layers = self
            .plans
            .iter()
            .zip(weights)
            .zip(&shapes)
            .enumerate()
            .map(|(k, ((p, w), s))| {
                let weight = match &p.kernel {
                    Kernel::Dense => {
                        let (n_out, n_in) = (s.weight[0], s.weight[1]);
                        let inl = self.input_layout(k);
                        let mut wt = vec![0.0; n_in * n_out];
                        for o in 0..n_out {
                            for i in 0..n_in {
                                wt[inl.internal(i) * n_out + o] = w.weight[o * n_in + i];
                            }
                        }
                        wt
                    }
                    Kernel::Conv { ic, oc, kk, .. } => {
                        let mut wt = vec![0.0; ic * kk * oc];
                        for o in 0..*oc {
                            for c in 0..*ic {
                                for q in 0..*kk {
                                    wt[(c * kk + q) * oc + o] = w.weight[(o * ic + c) * kk + q];
                                }
                            }
                        }
                        wt
                    }
                    Kernel::Pool { .. } => Vec::new(),
                };
                let recurrent = w.recurrent.as_ref().map_or_else(Vec::new, |r| {
                    let n = p.n_out;
                    let mut rt = vec![0.0; n * n];
                    for o in 0..n {
                        for i in 0..n {
                            rt[p.output.internal(i) * n + p.output.internal(o)] = r[o * n + i];
                        }
                    }
                    rt
                });
                Tensors { weight, bias: w.bias.clone().unwrap_or_default(), recurrent }
            })
            .collect();
        Ok(Params { layers })
    }

    /// `params` in the engine's layouts.
    pub fn weights(&self, params: &Params) -> snn::Result<Vec<LayerWeights>> {
        let shapes = self.spec.shapes()?;
        Ok(self
            .plans
            .iter()
            .zip(&params.layers)
            .zip(&shapes)
            .enumerate()
            .map(|(k, ((p, t), s))| {
                let weight = match &p.kernel {
                    Kernel::Dense => {
                        let (n_out, n_in) = (s.weight[0], s.weight[1]);
                        let inl = self.input_layout(k);
                        let mut w = vec![0.0; n_in * n_out];
                        for o in 0..n_out {
                            for i in 0..n_in {
                                w[o * n_in + i] = t.weight[inl.internal(i) * n_out + o];
                            }
                        }
                        w
                    }
                    Kernel::Conv { ic, oc, kk, .. } => {
                        let mut w = vec![0.0; ic * kk * oc];
                        for o in 0..*oc {
                            for c in 0..*ic {
                                for q in 0..*kk {
                                    w[(o * ic + c) * kk + q] = t.weight[(c * kk + q) * oc + o];
                                }
                            }
                        }
                        w
                    }
                    Kernel::Pool { .. } => Vec::new(),
                };
                let recurrent = p.recurrent.then(|| {
                    let n = p.n_out;
                    let mut r = vec![0.0; n * n];
                    for o in 0..n {
                        for i in 0..n {
                            r[o * n + i] = t.recurrent[p.output.internal(i) * n + p.output.internal(o)];
                        }
                    }
                    r
                });
                LayerWeights { weight, bias: (p.bias_len > 0).then(|| t.bias.clone()), recurrent, recurrent_bias: None }
            })
            .collect())
    }

    /// A sample's input events (network input indices, C order) in the internal layout.
    pub fn input_events(&self, events: StepEvents) -> StepEvents {
        let layout = self.input;
        events.map_indices(|i| layout.internal(i as usize) as u32)
    }

    /// Dropout masks of one sample: each hidden spiking neuron kept with probability
    /// `1 - dropout` (its spikes then scaled by `1 / (1 - dropout)`), as the twin's.
    pub fn dropout_masks(&self, dropout: f64, rng: &mut impl rand::Rng) -> Vec<Option<Vec<f32>>> {
        let last = self.plans.len().saturating_sub(1);
        self.plans
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let hidden_spiking = k < last && p.neurons.is_some_and(|n| n.kind != NeuronKind::Li);
                (dropout > 0.0 && hidden_spiking).then(|| {
                    let keep = (1.0 / (1.0 - dropout)) as f32;
                    (0..p.n_out).map(|_| if rng.random_bool(1.0 - dropout) { keep } else { 0.0 }).collect()
                })
            })
            .collect()
    }
}

#[cfg(test)]
impl SparseSnn {
    /// Every entry of the backward's kept buffers made NaN, so that a gradient computed after
    /// would show any entry it read without writing it first (tests). Returns how many.
    fn poison_buffers(&self) -> usize {
        let mut workers = self.scratch.workers.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let mut n = 0;
        for (_, pool) in workers.iter_mut() {
            for b in pool.iter_mut() {
                b.fill(f32::NAN);
                n += b.len();
            }
        }
        n
    }
}

#[cfg(all(test, feature = "train"))]
mod tests {
    use super::*;
    use crate::snn::{LayerParams, SnnParams, SnnTwin};
    use burn::module::Param;
    use burn::nn::loss::CrossEntropyLossConfig;
    use burn::tensor::{Device, Int, Tensor, TensorData};
    use rand::{Rng, SeedableRng};
    use snn::spec::LayerSpec;

    fn layer(op: OpSpec, neurons: Option<NeuronParams>, recurrent: bool, bias: bool) -> LayerSpec {
        LayerSpec { op, neurons, recurrent, bias, recurrent_bias: false }
    }

    fn two_layers(w0: f32, w1: f32) -> Params {
        let t = |w: f32| Tensors { weight: vec![w; 4], bias: vec![w; 2], recurrent: Vec::new() };
        Params { layers: vec![t(w0), t(w1)] }
    }

    #[test]
    fn distillation_is_the_cross_entropy_at_weight_zero_and_its_gradient_matches_the_loss() {
        let (logits, teacher) = ([1.5f32, -0.3, 4.0, 0.2], [3.0f32, 0.5, 2.0, -1.0]);
        let d = |weight, temperature| Distill { weight, temperature };
        assert_eq!(distillation(&logits, 1, &teacher, d(0.0, 4.0)), cross_entropy(&logits, 1));
        // a teacher equal to the student adds nothing at any weight
        let (l, g, _) = distillation(&logits, 2, &logits, d(1.0, 3.0));
        assert!(l.abs() < 1e-12 && g.iter().all(|g| g.abs() < 1e-6), "{l} {g:?}");
        // the gradient by central differences, at a mix
        for (w, t) in [(0.5, 4.0), (0.9, 2.0), (1.0, 1.0)] {
            let (_, g, hit) = distillation(&logits, 1, &teacher, d(w, t));
            assert!(!hit, "logit 2 is the highest");
            for k in 0..logits.len() {
                let at = |e: f32| {
                    let mut z = logits;
                    z[k] += e;
                    distillation(&z, 1, &teacher, d(w, t)).0
                };
                let numeric = (at(1e-3) - at(-1e-3)) / 2e-3;
                assert!((numeric - g[k] as f64).abs() < 1e-3, "weight {w}, T {t}, logit {k}: {numeric} vs {}", g[k]);
            }
        }
        // the soft term pulls toward the teacher's favourite even against the label
        let (_, g, _) = distillation(&[0.0, 0.0, 0.0, 0.0], 1, &[0.0, 0.0, 0.0, 9.0], d(1.0, 2.0));
        assert!(g[3] < 0.0 && g[1] > 0.0, "{g:?}");
    }

    #[test]
    fn a_frozen_layer_keeps_its_weights_and_the_anchor_pulls_toward_the_start() {
        let start = two_layers(1.0, -1.0);
        let grads = two_layers(0.5, 0.5);
        let mut frozen = start.clone();
        let mut adam = Adam::new(&frozen, 0.0, 0.0).with_frozen(vec![true, false]);
        adam.step(&mut frozen, &grads, 1e-2);
        assert_eq!(frozen.layers[0], start.layers[0], "the frozen layer moved");
        assert!(
            frozen.layers[1].weight.iter().all(|&w| w < -1.0),
            "the free layer did not move: {:?}",
            frozen.layers[1]
        );
        // a pull of lr * strength = 1 puts every weight back at its start after the step
        let mut pulled = start.clone();
        let mut adam = Adam::new(&pulled, 0.0, 0.0).with_anchor(&start, 100.0);
        adam.step(&mut pulled, &grads, 1e-2);
        assert_eq!(pulled, start);
        // half the pull: half the way back from where plain Adam would have gone
        let (mut plain, mut half) = (start.clone(), start.clone());
        Adam::new(&plain, 0.0, 0.0).step(&mut plain, &grads, 1e-2);
        Adam::new(&half, 0.0, 0.0).with_anchor(&start, 50.0).step(&mut half, &grads, 1e-2);
        for (h, (p, s)) in half.tensors().flatten().zip(plain.tensors().flatten().zip(start.tensors().flatten())) {
            assert!((h - (p + s) / 2.0).abs() < 1e-6, "{h} against {p} and {s}");
        }
    }

    /// Conv, IF, LIF, CubaLIF with recurrence, sum and average pooling, biases, both resets and
    /// both readouts.
    fn networks() -> Vec<(NetworkSpec, Readout)> {
        let conv = |out_channels, k, stride, padding| OpSpec::Conv2d {
            out_channels,
            kernel: [k, k],
            stride: [stride, stride],
            padding: [padding, padding],
        };
        let pool = |kind| OpSpec::Pool { kind, kernel: [2, 2], stride: [2, 2] };
        let cuba = NeuronParams::cuba_lif(0.7, 0.85).with_reset(Reset::Subtract);
        let a = NetworkSpec {
            input_shape: vec![2, 8, 10],
            layers: vec![
                layer(conv(4, 3, 1, 1), Some(NeuronParams::lif(0.8)), false, true),
                layer(pool(PoolKind::Sum), None, false, false),
                layer(OpSpec::Dense { n_out: 12 }, Some(cuba), true, true),
                layer(OpSpec::Dense { n_out: 5 }, Some(NeuronParams::leaky_integrator(0.9)), false, true),
            ],
        };
        let b = NetworkSpec {
            input_shape: vec![2, 9, 11],
            layers: vec![
                layer(
                    conv(3, 3, 2, 0),
                    Some(NeuronParams::integrate_and_fire().with_reset(Reset::Subtract)),
                    false,
                    false,
                ),
                layer(pool(PoolKind::Avg), None, false, false),
                layer(conv(5, 2, 1, 1), Some(NeuronParams::lif(0.9)), true, true),
                layer(OpSpec::Dense { n_out: 7 }, Some(cuba.with_reset(Reset::Zero)), true, false),
                layer(OpSpec::Dense { n_out: 4 }, Some(NeuronParams::lif(0.85)), false, false),
            ],
        };
        // 8 and 16 channels, the widths whose fan-outs are compiled for them (`conv_scatter`)
        let c = NetworkSpec {
            input_shape: vec![2, 9, 10],
            layers: vec![
                layer(conv(8, 3, 2, 1), Some(NeuronParams::lif(0.8)), false, false),
                layer(conv(16, 3, 2, 1), Some(NeuronParams::lif(0.85)), false, false),
                layer(OpSpec::Dense { n_out: 6 }, Some(NeuronParams::leaky_integrator(0.9)), false, false),
            ],
        };
        vec![(a, Readout::MaxMembrane), (b, Readout::SpikeCount), (c, Readout::MaxMembrane)]
    }

    /// Test case `case`'s weights (gain 3), a batch of three inputs of `steps` steps, and labels.
    #[allow(clippy::type_complexity)]
    fn case_data(
        case: usize,
        spec: &NetworkSpec,
        steps: usize,
    ) -> (Vec<LayerWeights>, Vec<Vec<(u32, u32, f32)>>, Vec<usize>) {
        let n_in: usize = spec.input_shape.iter().product();
        let n_out = spec.shapes().unwrap().last().unwrap().output.iter().product::<usize>();
        let weights = spec.init(10 + case as u64, 3.0).unwrap();
        let batch = inputs(20 + case as u64, 3, steps, n_in, 0.12);
        let labels: Vec<usize> = (0..batch.len()).map(|j| j % n_out).collect();
        (weights, batch, labels)
    }

    /// Random input counts (C order) of `batch` samples over `steps` steps.
    fn inputs(seed: u64, batch: usize, steps: usize, n: usize, p: f64) -> Vec<Vec<(u32, u32, f32)>> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..batch)
            .map(|_| {
                let mut e = Vec::new();
                for t in 0..steps as u32 {
                    for i in 0..n as u32 {
                        if rng.random_bool(p) {
                            e.push((t, i, rng.random_range(1..3) as f32));
                        }
                    }
                }
                e
            })
            .collect()
    }

    /// The twin's gradient of the mean cross-entropy, in engine layouts.
    fn burn_gradient(
        spec: &NetworkSpec,
        readout: Readout,
        weights: &[LayerWeights],
        batch: &[Vec<(u32, u32, f32)>],
        labels: &[usize],
        steps: usize,
    ) -> Vec<LayerWeights> {
        let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 5.0 }, readout).unwrap();
        let device = Device::flex().autodiff();
        let params = SnnParams::from_weights(spec, weights, &device).unwrap();
        let n: usize = spec.input_shape.iter().product();
        let b = batch.len();
        let out = twin.forward(&params, &crate::train::dense_input(batch, steps, n, &device));
        let y: Vec<i64> = labels.iter().map(|&l| l as i64).collect();
        let y = Tensor::<1, Int>::from_data(TensorData::new(y, [b]), &device);
        let loss = CrossEntropyLossConfig::new().init(&device).forward(out.logits, y);
        let grads = loss.backward();
        let plain = Device::flex();
        let grad = |p: &Option<Param<Tensor<2>>>| {
            p.as_ref()
                .map(|p| Param::from_tensor(Tensor::<2>::from_data(p.val().grad(&grads).unwrap().to_data(), &plain)))
        };
        let layers = params
            .layers
            .iter()
            .map(|l| LayerParams {
                dense: grad(&l.dense),
                conv: l.conv.as_ref().map(|p| {
                    Param::from_tensor(Tensor::<4>::from_data(p.val().grad(&grads).unwrap().to_data(), &plain))
                }),
                bias: l.bias.as_ref().map(|p| {
                    Param::from_tensor(Tensor::<1>::from_data(p.val().grad(&grads).unwrap().to_data(), &plain))
                }),
                recurrent: grad(&l.recurrent),
            })
            .collect();
        SnnParams { layers }.weights(spec).unwrap()
    }

    fn flat(w: &[LayerWeights]) -> Vec<f32> {
        w.iter()
            .flat_map(|l| {
                l.weight
                    .iter()
                    .chain(l.bias.iter().flatten())
                    .chain(l.recurrent.iter().flatten())
                    .copied()
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    #[test]
    fn layouts_round_trip() {
        for (spec, readout) in networks() {
            let net = SparseSnn::new(spec.clone(), Surrogate::FastSigmoid { slope: 5.0 }, readout, 0.0).unwrap();
            let w = spec.init(3, 1.0).unwrap();
            assert_eq!(net.weights(&net.params(&w).unwrap()).unwrap(), w);
        }
    }

    #[test]
    fn exact_gradients_equal_the_burn_twins_and_truncated_ones_stay_close() {
        let steps = 14;
        for (case, (spec, readout)) in networks().into_iter().enumerate() {
            let (weights, batch, labels) = case_data(case, &spec, steps);
            let want = flat(&burn_gradient(&spec, readout, &weights, &batch, &labels, steps));
            let surrogate = Surrogate::FastSigmoid { slope: 5.0 };
            let grad_masked = |cutoff: f32, dropout: f64| {
                let net = SparseSnn::new(spec.clone(), surrogate, readout, cutoff).unwrap();
                let params = net.params(&weights).unwrap();
                let events: Vec<StepEvents> =
                    batch.iter().map(|e| net.input_events(StepEvents::from_entries(steps, &mut e.clone()))).collect();
                let samples: Vec<(&StepEvents, usize)> = events.iter().zip(labels.iter().copied()).collect();
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
                let masks: Vec<_> = if dropout > 0.0 {
                    samples.iter().map(|_| net.dropout_masks(dropout, &mut rng)).collect()
                } else {
                    Vec::new()
                };
                let g = net.batch_gradient(&params, &samples, &masks);
                // every spiking layer spiked, so every path of the gradient was taken
                assert!(g.spikes.iter().all(|&s| s > 0.0), "case {case}: spikes per layer {:?}", g.spikes);
                flat(&net.weights(&g.grads).unwrap())
            };
            let grad = |cutoff: f32| grad_masked(cutoff, 0.0);
            let exact = grad(0.0);
            // exact, every surrogate kept in a dense tape, equals a truncation so far out that it
            // keeps them all in a list, to the bit (with and without dropout)
            let bits = |g: Vec<f32>| g.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for dropout in [0.0, 0.3] {
                let (dense, listed) = (grad_masked(0.0, dropout), grad_masked(1e-30, dropout));
                assert_eq!(bits(dense), bits(listed), "case {case}, dropout {dropout}");
            }
            let scale = want.iter().fold(0f32, |m, g| m.max(g.abs()));
            assert!(scale > 0.0);
            for (k, (a, b)) in exact.iter().zip(&want).enumerate() {
                assert!((a - b).abs() <= 1e-4 * scale + 1e-6, "case {case}, entry {k}: sparse {a} vs burn {b}");
            }
            // truncated at 5% of the surrogate's peak: close, not equal
            let cut = grad(0.05);
            let dot: f32 = cut.iter().zip(&want).map(|(a, b)| a * b).sum();
            let norm = |v: &[f32]| v.iter().map(|x| x * x).sum::<f32>().sqrt();
            let cosine = dot / (norm(&cut) * norm(&want));
            assert!(cosine > 0.9 && cut != exact, "case {case}: cosine {cosine}");
        }
    }

    #[test]
    fn the_forward_pass_is_the_engines() {
        use snn::engine::{Engine, Mode};
        for (spec, readout) in networks() {
            let weights = spec.init(4, 3.0).unwrap();
            let net = SparseSnn::new(spec.clone(), Surrogate::FastSigmoid { slope: 5.0 }, readout, 0.0).unwrap();
            let params = net.params(&weights).unwrap();
            let n_in: usize = spec.input_shape.iter().product();
            let steps = 12;
            for mut e in inputs(7, 3, steps, n_in, 0.1) {
                let out = net.forward(
                    &params,
                    &net.input_events(StepEvents::from_entries(steps, &mut e.clone())),
                    &[],
                    false,
                );
                let network = spec.build(weights.clone()).unwrap();
                let engine = Engine::new(&network, 1_000, Mode::Stepped).unwrap();
                let mut st = engine.state(0);
                e.sort_by_key(|x| x.0);
                for (t, i, c) in e {
                    engine.push(&mut st, t as i64 * 1_000 + 1, i, c).unwrap();
                }
                engine.finish(&mut st, steps as i64 * 1_000);
                let want: Vec<f32> = match readout {
                    Readout::SpikeCount => st.output_counts(net.n_outputs()).iter().map(|&c| c as f32).collect(),
                    Readout::MaxMembrane => st.output_v_max().iter().map(|v| v.max(0.0)).collect(),
                };
                for (a, b) in out.logits.iter().zip(&want) {
                    assert!((a - b).abs() <= 1e-4 * (1.0 + b.abs()), "{:?} vs {want:?}", out.logits);
                }
            }
        }
    }

    /// The backward's buffers are not zeroed between samples: each step's gradient by the layer
    /// below is read only where that step wrote it. With every kept entry made NaN before the
    /// second of two computations of one gradient, both give the same bits.
    #[test]
    fn gradients_read_nothing_left_in_the_kept_buffers() {
        let steps = 14;
        for (case, (spec, readout)) in networks().into_iter().enumerate() {
            let (weights, batch, labels) = case_data(case, &spec, steps);
            for cutoff in [0.0, 1e-30, 0.05] {
                let net = SparseSnn::new(spec.clone(), Surrogate::FastSigmoid { slope: 5.0 }, readout, cutoff).unwrap();
                let params = net.params(&weights).unwrap();
                let events: Vec<StepEvents> =
                    batch.iter().map(|e| net.input_events(StepEvents::from_entries(steps, &mut e.clone()))).collect();
                let samples: Vec<(&StepEvents, usize)> = events.iter().zip(labels.iter().copied()).collect();
                let bits = |g: &BatchGradient| g.grads.tensors().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
                let first = net.batch_gradient(&params, &samples, &[]);
                assert!(net.poison_buffers() > 0, "case {case}: buffers kept");
                let second = net.batch_gradient(&params, &samples, &[]);
                assert_eq!(bits(&first), bits(&second), "case {case}, cutoff {cutoff}");
            }
        }
    }

    /// The SSE dot product, the fused AVX update of the membranes and the AVX picking of the
    /// neurons near threshold give the portable code's bits, at every length (lanes and a rest),
    /// with zeros of both signs among the entries.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_kernels_equal_the_portable_code_to_the_bit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let draw = |n: usize, rng: &mut rand_chacha::ChaCha8Rng| -> Vec<f32> {
            (0..n)
                .map(|_| match rng.random_range(0..6) {
                    0 => 0.0,
                    1 => -0.0,
                    _ => rng.random_range(-2.0..2.0),
                })
                .collect()
        };
        for n in 0..70 {
            for _ in 0..20 {
                let (a, b) = (draw(n, &mut rng), draw(n, &mut rng));
                assert_eq!(sse_dot(&a, &b).to_bits(), portable_dot(&a, &b).to_bits(), "{a:?} . {b:?}");
            }
        }
        if !snn::engine::avx2() {
            return;
        }
        let mut above = 0;
        for n in 0..70 {
            for (beta, leak, low) in [(0.9f32, 0.0f32, 0.6f32), (0.75, 0.13, -0.2), (1.0, -0.05, 1.0)] {
                let (v, u) = (draw(n, &mut rng), draw(n, &mut rng));
                let (mut v1, mut u1, mut out1) = (v.clone(), u.clone(), Vec::new());
                let k1 = update_above::<false>(&mut v1, &mut u1, beta, leak, low, &mut out1);
                let (mut v2, mut u2, mut out2) = (v.clone(), u.clone(), Vec::new());
                // SAFETY: this CPU has AVX2 (just checked).
                let k2 = unsafe { avx_update_above(&mut v2, &mut u2, beta, leak, low, &mut out2) };
                let bits = |x: &[f32]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&v1), bits(&v2), "membranes, n {n}");
                assert_eq!(out1[..k1], out2[..k2], "indices above {low}, n {n}");
                assert!(u2.iter().all(|x| x.to_bits() == 0), "inputs emptied, n {n}");
                above += k1;
            }
        }
        assert!(above > 1000, "membranes above the line: {above}");
        // the lists of neurons near threshold that keep a surrogate or fire, appended to lists
        // already holding entries; NaN and both zeros among the distances
        let mut picked = 0;
        for n in 0..70 {
            let mut dist = draw(n, &mut rng);
            if n > 3 {
                dist[n / 2] = f32::NAN;
            }
            let near: Vec<u32> = (0..n as u32).map(|j| 3 * j + 1).collect();
            for keep in [Keep::Within(0.5), Keep::Within(1.5), Keep::Fired] {
                let (mut i1, mut v1) = (vec![7u32, 9], vec![0.25f32, -1.0]);
                let (mut i2, mut v2) = (i1.clone(), v1.clone());
                pick::<false>(keep, &near, &dist, &mut i1, Some(&mut v1));
                pick::<true>(keep, &near, &dist, &mut i2, Some(&mut v2));
                let expected: Vec<u32> =
                    near.iter().zip(&dist).filter(|&(_, &d)| keep.keeps(d)).map(|(&o, _)| o).collect();
                assert_eq!(i1[2..], expected, "{keep:?}, n {n}");
                assert_eq!(i1, i2, "{keep:?}, n {n}");
                let bits = |x: &[f32]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&v1), bits(&v2), "{keep:?}, n {n}");
                assert_eq!(i1.len(), v1.len(), "{keep:?}, n {n}");
                let (mut i3, mut i4) = (vec![5u32], vec![5u32]);
                pick::<false>(keep, &near, &dist, &mut i3, None);
                pick::<true>(keep, &near, &dist, &mut i4, None);
                assert_eq!(i3, i4, "{keep:?} without values, n {n}");
                picked += expected.len();
            }
        }
        assert!(picked > 1000, "neurons picked: {picked}");
    }

    /// The batched gathers of a convolution's and a dense layer's every input equal [`gather`]
    /// input by input, to the bit (zeros included), so the exact trainer's gradients are
    /// unchanged by them.
    #[test]
    fn batched_gathers_equal_gather_to_the_bit() {
        let net = snn::network::peers_conv(1, snn::network::PEER_GAIN);
        let trainer = SparseSnn::new(net.spec(), Surrogate::FastSigmoid { slope: 25.0 }, Readout::SpikeCount, 0.0)
            .expect("the peer network trains");
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let params = trainer.params(&net.weights()).expect("its own weights");
        let mut checked = 0;
        for (plan, p) in trainer.plans.iter().zip(&params.layers) {
            let g: Vec<f32> =
                (0..plan.n_out).map(|_| if rng.random_bool(0.3) { 0.0 } else { rng.random_range(-1.0..1.0) }).collect();
            // a dense layer's inputs: all of its own (a multiple of the lanes), and 13 (lanes
            // and a rest)
            let sizes: Vec<usize> = match &plan.kernel {
                Kernel::Conv { ic, kk, oc, .. } => vec![ic * kk * oc],
                Kernel::Dense => vec![p.weight.len(), 13 * plan.n_out],
                Kernel::Pool { .. } => continue,
            };
            for size in sizes {
                let w: Vec<f32> = (0..size).map(|_| rng.random_range(-1.0..1.0)).collect();
                let (n_in, batched) = match (&plan.kernel, weights_by_input(plan, &w)) {
                    (Kernel::Conv { ic, offsets, .. }, Some(ByInput::Conv(wt))) => {
                        let n_in = (offsets.len() - 1) * ic;
                        let mut batched = vec![f32::NAN; n_in];
                        gather_all_conv(plan, &wt, &g, &mut batched);
                        (n_in, batched)
                    }
                    (Kernel::Dense, Some(ByInput::Dense(wt))) => {
                        let n_in = size / plan.n_out;
                        let mut batched = vec![f32::NAN; n_in];
                        gather_all_dense(&wt, plan.n_out, &g, &mut batched);
                        (n_in, batched)
                    }
                    _ => continue,
                };
                assert_eq!(batched.len(), n_in);
                for (i, b) in batched.iter().enumerate() {
                    assert_eq!(b.to_bits(), gather(plan, &w, i, &g).to_bits(), "input {i} of {n_in}");
                }
                checked += 1;
            }
        }
        assert_eq!(checked, 3, "the peer network's second convolution and its dense layer, twice");
    }
}
