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

pub mod chip;

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

    /// One sample forward (internal input layout, [`Self::input_events`]); with `tape`, what
    /// the backward pass needs is kept.
    pub fn forward(&self, params: &Params, input: &StepEvents, masks: &[Option<Vec<f32>>], tape: bool) -> SampleOutput {
        self.forward_into(params, input, masks, tape, Vec::new())
    }

    /// [`Self::forward`] into the buffers of `spare`, a previous sample's tape.
    fn forward_into(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        tape: bool,
        spare: Vec<LayerTape>,
    ) -> SampleOutput {
        #[cfg(target_arch = "x86_64")]
        if snn::engine::avx2() {
            // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
            return unsafe { self.forward_avx2(params, input, masks, tape, spare) };
        }
        self.forward_with::<false>(params, input, masks, tape, spare)
    }

    /// [`Self::forward`] compiled for AVX2: the same operations (nothing fused or reordered), in
    /// wider registers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    fn forward_avx2(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        tape: bool,
        spare: Vec<LayerTape>,
    ) -> SampleOutput {
        self.forward_with::<true>(params, input, masks, tape, spare)
    }

    #[inline(always)]
    fn forward_with<const AVX: bool>(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        tape: bool,
        spare: Vec<LayerTape>,
    ) -> SampleOutput {
        let steps = input.steps();
        let last = self.plans.len() - 1;
        let mut spare = spare.into_iter();
        // exact: every neuron keeps its surrogate, stored densely (`LayerTape::surr_all`)
        let all = tape && self.x_cut == f32::INFINITY;
        let mut layers: Vec<LayerTape> = Vec::with_capacity(self.plans.len());
        let mut v_max = Vec::new();
        for (k, plan) in self.plans.iter().enumerate() {
            let x = if k == 0 { input } else { &layers[k - 1].out };
            let w = &params.layers[k];
            let n = plan.n_out;
            let mask = masks.get(k).and_then(Option::as_deref);
            let mut lt = spare.next().map_or_else(LayerTape::default, LayerTape::cleared);
            if all {
                lt.surr_all.reserve(steps * n);
            }
            let (mut u, mut v, mut cur) = (vec![0f32; n], vec![0f32; n], vec![0f32; n]);
            let (mut near_buf, mut dist) = (Vec::new(), Vec::new());
            let li = plan.neurons.is_some_and(|p| p.kind == NeuronKind::Li);
            if li {
                v_max = vec![f32::NEG_INFINITY; n];
                lt.argmax = vec![0; n];
            }
            // whether `u` is all zeros already (the spiking layers' update empties it with AVX2)
            let mut emptied = true;
            for t in 0..steps {
                if plan.bias_len > 0 {
                    for (o, u) in u.iter_mut().enumerate() {
                        *u = w.bias[o % plan.bias_len];
                    }
                } else if !emptied {
                    u.fill(0.0);
                }
                emptied = false;
                let (xi, xv) = x.at(t);
                for (&i, &xv) in xi.iter().zip(xv) {
                    scatter(plan, &w.weight, i as usize, xv, &mut u);
                }
                if plan.recurrent && t > 0 {
                    let (ji, jv) = lt.spikes.at(t - 1);
                    for (&j, &s) in ji.iter().zip(jv) {
                        axpy(&mut u, &w.recurrent[j as usize * n..][..n], s);
                    }
                }
                match plan.neurons {
                    None => {
                        for (o, &u) in u.iter().enumerate() {
                            if u != 0.0 {
                                lt.out.push(o as u32, u);
                            }
                        }
                    }
                    Some(np) if li => {
                        let leak = np.leak_term();
                        for o in 0..n {
                            let vp = v[o] * np.beta + leak + u[o];
                            v[o] = vp;
                            if vp > v_max[o] {
                                v_max[o] = vp;
                                lt.argmax[o] = t as u32;
                            }
                            if k < last && vp != 0.0 {
                                lt.out.push(o as u32, vp);
                            }
                        }
                    }
                    Some(np) => {
                        // dense and branch-free first (it vectorises), then the few near threshold
                        let leak = np.leak_term();
                        if np.kind == NeuronKind::CubaLif {
                            for (c, u) in cur.iter_mut().zip(u.iter_mut()) {
                                *c = *c * np.alpha + *u;
                                *u = *c;
                            }
                        }
                        // the membranes updated and those above `low` listed (with AVX2 in one
                        // pass, which also empties `u`); exact: every neuron's derivative,
                        // densely (it vectorises); else those of the neurons near threshold, below
                        let low = if tape && !all { np.v_th - self.x_cut } else { np.v_th };
                        let found = update_above::<AVX>(&mut v, &mut u, np.beta, leak, low, &mut near_buf);
                        emptied = AVX;
                        if all {
                            let start = lt.surr_all.len();
                            lt.surr_all.extend(v.iter().map(|&v| v - np.v_th));
                            derivatives_in_place(self.surrogate, &mut lt.surr_all[start..]);
                        }
                        let near = &near_buf[..found];
                        // their distances to threshold
                        dist.clear();
                        dist.extend(near.iter().map(|&o| v[o as usize] - np.v_th));
                        // those within the truncation keep a surrogate, listed without a branch,
                        // their derivatives then taken all at once (it vectorises)
                        if tape && !all {
                            let kept = lt.surr.idx.len();
                            let within = Keep::Within(self.x_cut);
                            pick::<AVX>(within, near, &dist, &mut lt.surr.idx, Some(&mut lt.surr.val));
                            derivatives_in_place(self.surrogate, &mut lt.surr.val[kept..]);
                        }
                        // the spiking neurons among them, also listed without a branch
                        let fired = lt.spikes.idx.len();
                        pick::<AVX>(Keep::Fired, near, &dist, &mut lt.spikes.idx, None);
                        lt.spikes.val.resize(lt.spikes.idx.len(), 1.0);
                        if mask.is_none() {
                            // what the next layer receives: the spikes themselves
                            lt.out.idx.extend_from_slice(&lt.spikes.idx[fired..]);
                            lt.out.val.resize(lt.out.idx.len(), 1.0);
                        }
                        for &o in &lt.spikes.idx[fired..] {
                            let o = o as usize;
                            if let Some(m) = mask
                                && m[o] != 0.0
                            {
                                lt.out.push(o as u32, m[o]);
                            }
                            let v = &mut v[o];
                            *v = match np.reset {
                                Reset::Subtract => *v - np.v_th,
                                Reset::Zero => np.v_reset,
                            };
                        }
                    }
                }
                lt.out.end_step();
                lt.spikes.end_step();
                lt.surr.end_step();
            }
            lt.n_spikes = lt.spikes.len();
            layers.push(lt);
        }
        self.output(layers, v_max, steps, tape, false)
    }

    /// The forward pass's result from its layers' tapes and the readout's highest membranes.
    fn output(&self, layers: Vec<LayerTape>, v_max: Vec<f32>, steps: usize, tape: bool, delayed: bool) -> SampleOutput {
        let last = self.plans.len() - 1;
        let out = &self.plans[last];
        let mut counts = vec![0f32; out.n_out];
        let (oi, ov) = (&layers[last].spikes.idx, &layers[last].spikes.val);
        for (&o, &s) in oi.iter().zip(ov) {
            counts[o as usize] += s;
        }
        let logits = (0..out.n_out)
            .map(|c| {
                let o = out.output.internal(c);
                match self.readout {
                    Readout::SpikeCount => counts[o],
                    Readout::MaxMembrane if steps == 0 => 0.0,
                    Readout::MaxMembrane => v_max[o].max(0.0),
                }
            })
            .collect();
        let spikes = self
            .plans
            .iter()
            .zip(&layers)
            .filter(|(p, _)| p.neurons.is_some_and(|n| n.kind != NeuronKind::Li))
            .map(|(_, l)| l.n_spikes)
            .collect();
        SampleOutput { logits, spikes, tape: if tape { layers } else { Vec::new() }, v_max, delayed }
    }

    /// One sample backward: adds the gradient of the loss, given `g_logits` (its gradient by the
    /// logits, in class order), into `grads`.
    pub fn backward(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        let by_input = self.weights_by_input(params);
        let mut work = Workspace { params, by_input: &by_input, pool: &mut Vec::new() };
        self.backward_by(&mut work, input, masks, out, g_logits, grads)
    }

    /// Each layer's weights laid out for gathering the gradient of all its inputs at once (none
    /// for the first layer): made once per batch.
    fn weights_by_input(&self, params: &Params) -> Vec<Option<ByInput>> {
        self.plans
            .iter()
            .zip(&params.layers)
            .enumerate()
            .map(|(k, (plan, w))| if k == 0 { None } else { weights_by_input(plan, &w.weight) })
            .collect()
    }

    /// [`Self::backward`] in a worker's [`Workspace`].
    fn backward_by(
        &self,
        work: &mut Workspace,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        #[cfg(target_arch = "x86_64")]
        if snn::engine::avx2() {
            // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
            return unsafe { self.backward_avx2(work, input, masks, out, g_logits, grads) };
        }
        self.backward_with(work, input, masks, out, g_logits, grads)
    }

    /// [`Self::backward`] compiled for AVX2 (the same operations, as [`Self::forward_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    fn backward_avx2(
        &self,
        work: &mut Workspace,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        self.backward_with(work, input, masks, out, g_logits, grads)
    }

    #[inline(always)]
    fn backward_with(
        &self,
        work: &mut Workspace,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        let steps = input.steps();
        let last = self.plans.len() - 1;
        let tape = &out.tape;
        assert_eq!(tape.len(), self.plans.len(), "backward needs a forward pass with its tape");
        let top = &self.plans[last];
        // the readout's gradient by internal index
        let mut g_read = vec![0f32; top.n_out];
        for (c, &g) in g_logits.iter().enumerate() {
            let o = top.output.internal(c);
            let clamped = self.readout == Readout::MaxMembrane && self.clamped_readout_gradient && out.v_max[o] < 0.0;
            g_read[o] = if clamped { 0.0 } else { g };
        }
        // (pool buffers: as many taken as given back)
        let (params, pool) = (work.params, &mut *work.pool);
        let mut g_out = pool.pop().unwrap_or_default();
        g_out.clear();
        match self.readout {
            Readout::SpikeCount => (0..steps).for_each(|_| g_out.extend_from_slice(&g_read)),
            Readout::MaxMembrane => g_out.resize(steps * top.n_out, 0.0),
        }
        for k in (0..=last).rev() {
            let plan = &self.plans[k];
            let (w, gw, lt) = (&params.layers[k], &mut grads.layers[k], &tape[k]);
            let x = if k == 0 { input } else { &tape[k - 1].out };
            // the step of the layer below whose output this layer takes at step t
            let delay = usize::from(out.delayed && k > 0);
            let n = plan.n_out;
            let mask = masks.get(k).and_then(Option::as_deref);
            let below = k.checked_sub(1).map(|b| (&self.plans[b], &tape[b]));
            let nb = below.map_or(0, |(b, _)| b.n_out);
            // The layer below reads at each step only what is written into this buffer at that
            // step below: the gradient of its inputs that keep a surrogate (it reads only theirs),
            // or of all of them. So the buffer is not zeroed (zeroing a sample's worth was a
            // few percent of a step), but for the last `delay` steps, which no step writes.
            let mut g_below = pool.pop().unwrap_or_default();
            g_below.resize(steps * nb, 0.0);
            g_below[steps.saturating_sub(delay) * nb..].fill(0.0);
            // the weights laid out by input, for the steps where every input keeps a surrogate
            // (the exact gradient): eight inputs gathered at once
            let by_input = work.by_input[k].as_ref();
            let (mut g_u, mut carry_v, mut carry_i, mut g_rec) =
                (vec![0f32; n], vec![0f32; n], vec![0f32; n], vec![0f32; n]);
            for t in (0..steps).rev() {
                let go = &g_out[t * n..][..n];
                match plan.neurons {
                    None => g_u.copy_from_slice(go),
                    Some(np) => {
                        if np.kind == NeuronKind::Li {
                            std::mem::swap(&mut g_u, &mut carry_v); // carry_v is rewritten below
                            if k == last {
                                for (o, g) in g_u.iter_mut().enumerate() {
                                    if lt.argmax[o] as usize == t {
                                        *g += g_read[o];
                                    }
                                }
                            } else {
                                g_u.iter_mut().zip(go).for_each(|(g, d)| *g += d);
                            }
                        } else {
                            if np.reset == Reset::Zero {
                                for &j in lt.spikes.at(t).0 {
                                    carry_v[j as usize] = 0.0;
                                }
                            }
                            std::mem::swap(&mut g_u, &mut carry_v); // carry_v is rewritten below
                            match lt.kept(t, n) {
                                Kept::All(sv) => match mask {
                                    None => surrogate_all(&mut g_u, sv, go, &g_rec),
                                    Some(m) => {
                                        for ((((g, &s), &go), &gr), &m) in
                                            g_u.iter_mut().zip(sv).zip(go).zip(&g_rec).zip(m)
                                        {
                                            *g += (go * m + gr) * s;
                                        }
                                    }
                                },
                                Kept::Listed(si, sv) => {
                                    for (&o, &s) in si.iter().zip(sv) {
                                        let o = o as usize;
                                        let gz = go[o] * mask.map_or(1.0, |m| m[o]) + g_rec[o];
                                        g_u[o] += gz * s;
                                    }
                                }
                            }
                        }
                        for (c, g) in carry_v.iter_mut().zip(&g_u) {
                            *c = np.beta * g;
                        }
                        if np.kind == NeuronKind::CubaLif {
                            for (g, c) in g_u.iter_mut().zip(carry_i.iter_mut()) {
                                *g += np.alpha * *c;
                                *c = *g;
                            }
                        }
                    }
                }
                if plan.bias_len > 0 {
                    for (o, g) in g_u.iter().enumerate() {
                        gw.bias[o % plan.bias_len] += g;
                    }
                }
                let src = t.checked_sub(delay);
                if let Some(ts) = src {
                    let (xi, xv) = x.at(ts);
                    for (&i, &xv) in xi.iter().zip(xv) {
                        weight_grad(plan, &mut gw.weight, i as usize, xv, &g_u);
                    }
                }
                if plan.recurrent {
                    g_rec.fill(0.0);
                    if t > 0 {
                        let (ji, jv) = lt.spikes.at(t - 1);
                        for (&j, &s) in ji.iter().zip(jv) {
                            axpy(&mut gw.recurrent[j as usize * n..][..n], &g_u, s);
                        }
                        match lt.kept(t - 1, n) {
                            Kept::All(_) => {
                                for (j, g) in g_rec.iter_mut().enumerate() {
                                    *g = dot(&w.recurrent[j * n..][..n], &g_u);
                                }
                            }
                            Kept::Listed(ji, _) => {
                                for &j in ji {
                                    g_rec[j as usize] = dot(&w.recurrent[j as usize * n..][..n], &g_u);
                                }
                            }
                        }
                    }
                }
                if let (Some((b, bt)), Some(ts)) = (below, src) {
                    let gb = &mut g_below[ts * nb..][..nb];
                    // the inputs whose gradient is needed: those keeping a surrogate, or all
                    let kept = match b.neurons {
                        Some(bn) if bn.kind != NeuronKind::Li => match bt.kept(ts, nb) {
                            Kept::Listed(kept, _) if kept.len() < nb => Some(kept),
                            _ => None,
                        },
                        _ => None,
                    };
                    match (kept, by_input) {
                        (None, Some(ByInput::Conv(wt))) => gather_all_conv(plan, wt, &g_u, gb),
                        (None, Some(ByInput::Dense(wt))) => gather_all_dense(wt, n, &g_u, gb),
                        (Some(kept), _) => {
                            for &i in kept {
                                gb[i as usize] = gather(plan, &w.weight, i as usize, &g_u);
                            }
                        }
                        (None, None) => {
                            for (i, g) in gb.iter_mut().enumerate() {
                                *g = gather(plan, &w.weight, i, &g_u);
                            }
                        }
                    }
                }
            }
            pool.push(std::mem::replace(&mut g_out, g_below));
        }
        pool.push(g_out);
    }

    /// The gradient of the mean cross-entropy over a batch of `(input events, label)`, with a
    /// dropout mask set per sample (`masks[j]`, or none).
    pub fn batch_gradient(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
    ) -> BatchGradient {
        self.float_gradient(params, samples, masks, |_, logits, label| cross_entropy(logits, label))
    }

    /// [`Self::batch_gradient`] of the distillation loss ([`distillation`]): sample `j` learns
    /// from its label and from `teacher[j]`, a trained network's logits on the same sample.
    ///
    /// # Panics
    /// When `teacher` and `samples` differ in length (a caller's bug:
    /// [`crate::train::train_distilled`] checks its teacher before training).
    pub fn distilled_gradient(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
        teacher: &[&[f32]],
        d: Distill,
    ) -> BatchGradient {
        assert_eq!(teacher.len(), samples.len(), "a teacher's logits for each sample");
        self.float_gradient(params, samples, masks, |j, logits, label| distillation(logits, label, teacher[j], d))
    }

    /// The float network's gradient of `loss` (of sample `j`'s logits and label).
    fn float_gradient(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
        loss: impl Fn(usize, &[f32], usize) -> (f64, Vec<f32>, bool) + Sync,
    ) -> BatchGradient {
        let forward = |x: &StepEvents, m: &[Option<Vec<f32>>], spare: Vec<LayerTape>| {
            Ok(self.forward_into(params, x, m, true, spare))
        };
        let Ok(g) = self.gradient_with::<std::convert::Infallible>(params, samples, masks, forward, loss);
        g
    }

    /// [`Self::batch_gradient`] with the forward pass `forward` (taped): the float network's, or
    /// a chip's ([`chip`]); `loss` of sample `j` (its index in `samples`), its logits and label.
    fn gradient_with<E: Send>(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
        forward: impl Fn(&StepEvents, &[Option<Vec<f32>>], Vec<LayerTape>) -> Result<SampleOutput, E> + Sync,
        loss: impl Fn(usize, &[f32], usize) -> (f64, Vec<f32>, bool) + Sync,
    ) -> Result<BatchGradient, E> {
        let b = samples.len().max(1);
        let chunk = b.div_ceil(CHUNKS);
        let empty = || BatchGradient {
            grads: self.scratch.zeros_like(params),
            loss_sum: 0.0,
            hits: 0,
            spikes: Vec::new(),
            kept_surrogates: 0,
        };
        let by_input = self.weights_by_input(params);
        let parts: Vec<BatchGradient> = samples
            .par_chunks(chunk)
            .enumerate()
            // each worker's buffers (a tape, the backward's step-by-step gradients) reused from
            // sample to sample and batch to batch: results do not depend on them
            .map_init(
                || WorkerBuffers::take(&self.scratch),
                |buffers, (c, part)| {
                    let WorkerBuffers { tape: spare, pool, .. } = buffers;
                    let mut work = Workspace { params, by_input: &by_input, pool };
                    let mut acc = empty();
                    for (j, &(input, label)) in part.iter().enumerate() {
                        let m: &[Option<Vec<f32>>] = masks.get(c * chunk + j).map_or(&[], Vec::as_slice);
                        let out = forward(input, m, std::mem::take(spare))?;
                        let (loss, mut g, hit) = loss(c * chunk + j, &out.logits, label);
                        g.iter_mut().for_each(|g| *g /= b as f32);
                        self.backward_by(&mut work, input, m, &out, &g, &mut acc.grads);
                        acc.loss_sum += loss;
                        acc.kept_surrogates += out.tape.iter().map(LayerTape::n_kept).sum::<usize>();
                        acc.hits += hit as usize;
                        add_spikes(&mut acc.spikes, out.spikes.iter().map(|&s| s as f64));
                        *spare = out.tape;
                    }
                    Ok(acc)
                },
            )
            .collect::<Result<_, E>>()?;
        let mut parts = parts.into_iter();
        let mut total = parts.next().unwrap_or_else(empty);
        for p in parts {
            total.grads.add(&p.grads);
            total.loss_sum += p.loss_sum;
            total.hits += p.hits;
            total.kept_surrogates += p.kept_surrogates;
            add_spikes(&mut total.spikes, p.spikes.iter().copied());
            self.scratch.keep_grads(p.grads);
        }
        Ok(total)
    }

    /// Forward passes of `inputs` in parallel (no tape): each one's logits and spikes per layer.
    pub fn infer(&self, params: &Params, inputs: &[&StepEvents]) -> Vec<(Vec<f32>, Vec<usize>)> {
        inputs
            .par_iter()
            .map(|x| {
                let out = self.forward(params, x, &[], false);
                (out.logits, out.spikes)
            })
            .collect()
    }
}

fn add_spikes(acc: &mut Vec<f64>, s: impl ExactSizeIterator<Item = f64>) {
    acc.resize(s.len().max(acc.len()), 0.0);
    acc.iter_mut().zip(s).for_each(|(a, s)| *a += s);
}

/// Cross-entropy of `logits` against `label`: the loss, its gradient by the logits, and whether
/// the highest logit (the first of ties) is the label.
pub fn cross_entropy(logits: &[f32], label: usize) -> (f64, Vec<f32>, bool) {
    let m = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let e: Vec<f64> = logits.iter().map(|&l| ((l - m) as f64).exp()).collect();
    let s: f64 = e.iter().sum();
    let loss = -((logits[label] - m) as f64 - s.ln());
    let g = e.iter().enumerate().map(|(c, &e)| (e / s) as f32 - (c == label) as u32 as f32).collect();
    let best = logits.iter().enumerate().fold(0, |b, (c, &l)| if l > logits[b] { c } else { b });
    (loss, g, best == label)
}

/// Knowledge distillation's mix of losses (Hinton, Vinyals and Dean 2015): `1 - weight` of the
/// cross-entropy against the label and `weight` of `temperature^2` times the Kullback-Leibler
/// divergence of the student's softened distribution (`softmax(logits / T)`) from the teacher's
/// (`softmax(teacher / T)`); `T^2` keeps the soft term's gradient at the hard term's scale.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Distill {
    /// The soft term's share, in [0, 1].
    pub weight: f32,
    /// `T`, above 0.
    pub temperature: f32,
}

/// [`Distill`]'s loss of `logits` against `label` and the teacher's logits: the loss, its
/// gradient by the logits, and whether the highest logit (the first of ties) is the label.
pub fn distillation(logits: &[f32], label: usize, teacher: &[f32], d: Distill) -> (f64, Vec<f32>, bool) {
    let (hard, g_hard, hit) = cross_entropy(logits, label);
    let t = d.temperature as f64;
    let (q, p) = (softmax_at(logits, d.temperature), softmax_at(teacher, d.temperature));
    let kl: f64 = p.iter().zip(&q).filter(|(p, _)| **p > 0.0).map(|(p, q)| p * (p.ln() - q.ln())).sum();
    let w = d.weight as f64;
    let loss = (1.0 - w) * hard + w * t * t * kl;
    // d(T^2 KL)/dz = T (q - p)
    let g = g_hard
        .iter()
        .zip(q.iter().zip(&p))
        .map(|(&h, (q, p))| ((1.0 - w) * h as f64 + w * t * (q - p)) as f32)
        .collect();
    (loss, g, hit)
}

/// `softmax(z / temperature)`, in f64 (the distributions [`distillation`] compares).
pub fn softmax_at(z: &[f32], temperature: f32) -> Vec<f64> {
    let (m, t) = (z.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64, temperature as f64);
    let e: Vec<f64> = z.iter().map(|&l| ((l as f64 - m) / t).exp()).collect();
    let s: f64 = e.iter().sum();
    e.into_iter().map(|e| e / s).collect()
}

/// `|x|` beyond which `surrogate`'s derivative is below `cutoff` times its peak (infinite for 0).
fn truncation_width(surrogate: Surrogate, cutoff: f32) -> f32 {
    if cutoff <= 0.0 {
        return f32::INFINITY;
    }
    match surrogate {
        // 1 / (1 + s x)^2 = c
        Surrogate::FastSigmoid { slope } => (1.0 / cutoff.sqrt() - 1.0) / slope,
        // 1 / (1 + a^2) = c, a = pi alpha x / 2
        Surrogate::Arctan { alpha } => 2.0 * (1.0 / cutoff - 1.0).sqrt() / (std::f32::consts::PI * alpha),
        Surrogate::Triangle { width } => width * (1.0 - cutoff),
    }
}

/// The indices of `v` above `low`, ascending, into the front of `out` (kept at least
/// `v.len() + 4` long, so that it is not cleared each step): how many. Without a branch per
/// index: four membranes compared at once into a 4-bit mask, whose set lanes' offsets come
/// packed from a table ([`PACK4`]) and are stored four at a time, the end advancing by their
/// count.
#[inline(always)]
fn above(v: &[f32], low: f32, out: &mut Vec<u32>) -> usize {
    if out.len() < v.len() + 4 {
        out.resize(v.len() + 4, 0);
    }
    let mut k = 0;
    let quads = v.len() / 4;
    for (q, x) in v.chunks_exact(4).enumerate() {
        let mask = lanes_above(x.try_into().expect("four lanes"), low);
        let (offsets, count) = PACK4[mask];
        let base = (4 * q) as u32;
        let slot: &mut [u32; 4] = (&mut out[k..k + 4]).try_into().expect("four slots");
        for (s, o) in slot.iter_mut().zip(offsets) {
            *s = base + o;
        }
        k += count;
    }
    for (j, &x) in v.iter().enumerate().skip(4 * quads) {
        out[k] = j as u32;
        k += (x > low) as usize;
    }
    k
}

/// The membranes' update `v <- v beta + leak + u` and [`above`] of the new membranes: the
/// indices of `v` above `low`, ascending, into the front of `out`; returns how many. With `AVX`
/// (set only in code compiled for AVX2 and run where the CPU has it) in one pass over both,
/// eight lanes at a time, `u` emptied on the way.
#[inline(always)]
fn update_above<const AVX: bool>(
    v: &mut [f32],
    u: &mut [f32],
    beta: f32,
    leak: f32,
    low: f32,
    out: &mut Vec<u32>,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is set only by `forward_avx2`, which runs where AVX2, popcnt and BMI1 are.
        return unsafe { avx_update_above(v, u, beta, leak, low, out) };
    }
    for (v, &drive) in v.iter_mut().zip(u.iter()) {
        *v = *v * beta + leak + drive;
    }
    above(v, low, out)
}

/// [`update_above`] in AVX registers: per eight membranes, the same operations in the same order
/// (nothing fused), one compare, and the lanes above `low` packed to the front of a register (a
/// permutation from [`snn::engine::PACKED_LANES`]) and stored at the list's end, which advances
/// by their number.
///
/// # Safety
/// The CPU must have AVX2, popcnt and BMI1 ([`snn::engine::avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,popcnt")]
#[inline]
unsafe fn avx_update_above(v: &mut [f32], u: &mut [f32], beta: f32, leak: f32, low: f32, out: &mut Vec<u32>) -> usize {
    use std::arch::x86_64::{
        __m256i, _CMP_GT_OQ, _mm256_add_epi32, _mm256_add_ps, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_loadu_si256,
        _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps,
        _mm256_storeu_si256,
    };
    assert_eq!(v.len(), u.len(), "a drive per membrane");
    if out.len() < v.len() + 8 {
        out.resize(v.len() + 8, 0);
    }
    let (b, l, lo) = (_mm256_set1_ps(beta), _mm256_set1_ps(leak), _mm256_set1_ps(low));
    let mut k = 0;
    let whole = v.len() / 8 * 8;
    for (q, (x, d)) in v.chunks_exact_mut(8).zip(u.chunks_exact_mut(8)).enumerate() {
        let slot: &mut [u32; 8] = (&mut out[k..k + 8]).try_into().expect("eight slots");
        // SAFETY: `x`, `d` and `slot` are eight f32s or u32s each (unaligned access allowed);
        // AVX2 (this function's contract).
        let mask = unsafe {
            let nv = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(x.as_ptr()), b), l),
                _mm256_loadu_ps(d.as_ptr()),
            );
            _mm256_storeu_ps(x.as_mut_ptr(), nv);
            _mm256_storeu_ps(d.as_mut_ptr(), _mm256_setzero_ps());
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(nv, lo)) as usize;
            let lanes = _mm256_loadu_si256(PACKED_LANES.0[mask].as_ptr().cast::<__m256i>());
            let at = _mm256_add_epi32(lanes, _mm256_set1_epi32((8 * q) as i32));
            _mm256_storeu_si256(slot.as_mut_ptr().cast::<__m256i>(), at);
            mask
        };
        k += mask.count_ones() as usize;
    }
    for j in whole..v.len() {
        v[j] = v[j] * beta + leak + u[j];
        u[j] = 0.0;
        out[k] = j as u32;
        k += (v[j] > low) as usize;
    }
    k
}

/// Which neurons near threshold [`pick`] lists, by their distance `d` to it.
#[derive(Debug, Clone, Copy)]
enum Keep {
    /// `|d| < x_cut`: their surrogate derivative is kept (`x_cut`: the truncation's width).
    Within(f32),
    /// `d > 0`: they fire.
    Fired,
}

impl Keep {
    #[inline(always)]
    fn keeps(self, d: f32) -> bool {
        match self {
            Keep::Within(x_cut) => d.abs() < x_cut,
            Keep::Fired => d > 0.0,
        }
    }
}

/// Appends to `idx` the neurons of `near` whose distance to threshold (`dist`, the same order)
/// `keep` keeps, in order, and those distances to `val` when given: without a branch per neuron.
/// With `AVX` (set only in code compiled for AVX2 and run where the CPU has it) eight at a time,
/// the kept lanes packed to the front of a register by a permutation from
/// [`snn::engine::PACKED_LANES`] (the same lists).
#[inline(always)]
fn pick<const AVX: bool>(keep: Keep, near: &[u32], dist: &[f32], idx: &mut Vec<u32>, mut val: Option<&mut Vec<f32>>) {
    assert_eq!(near.len(), dist.len(), "a distance per neuron");
    let start = idx.len();
    assert!(val.as_deref().is_none_or(|v| v.len() == start), "a value per listed neuron");
    // room for a whole register written past the last kept entry
    idx.resize(start + near.len() + 8, 0);
    if let Some(val) = val.as_deref_mut() {
        val.resize(start + near.len() + 8, 0.0);
    }
    #[cfg(target_arch = "x86_64")]
    let (mut end, done) = if AVX {
        // SAFETY: `AVX` is set only by `forward_avx2`, which runs where AVX2, popcnt and BMI1 are.
        unsafe { avx_pick(keep, near, dist, idx, val.as_mut().map(|v| v.as_mut_slice()), start) }
    } else {
        (start, 0)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let (mut end, done) = (start, 0);
    for (&o, &d) in near.iter().zip(dist).skip(done) {
        idx[end] = o;
        if let Some(val) = val.as_deref_mut() {
            val[end] = d;
        }
        end += keep.keeps(d) as usize;
    }
    idx.truncate(end);
    if let Some(val) = val {
        val.truncate(end);
    }
}

/// [`pick`]'s whole registers: the kept entries of the first `near.len() / 8 * 8` written from
/// `idx[start]` (and `val[start]`) on; returns the end of the list and the entries read. `idx`
/// and `val` have room for eight entries past `start + near.len()`.
///
/// # Safety
/// The CPU must have AVX2, popcnt and BMI1 ([`snn::engine::avx2`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,popcnt")]
#[inline]
unsafe fn avx_pick(
    keep: Keep,
    near: &[u32],
    dist: &[f32],
    idx: &mut [u32],
    mut val: Option<&mut [f32]>,
    start: usize,
) -> (usize, usize) {
    use std::arch::x86_64::{
        __m256i, _CMP_GT_OQ, _CMP_LT_OQ, _mm256_and_ps, _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_loadu_ps,
        _mm256_loadu_si256, _mm256_movemask_ps, _mm256_permutevar8x32_epi32, _mm256_permutevar8x32_ps,
        _mm256_set1_epi32, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps, _mm256_storeu_si256,
    };
    let mut end = start;
    let whole = near.len() / 8 * 8;
    for (o8, d8) in near[..whole].chunks_exact(8).zip(dist[..whole].chunks_exact(8)) {
        let slot: &mut [u32; 8] = (&mut idx[end..end + 8]).try_into().expect("eight slots");
        // SAFETY: `o8`, `d8` and `slot` are eight u32s or f32s each (unaligned access allowed);
        // AVX2 (this function's contract).
        let (mask, perm, d) = unsafe {
            let d = _mm256_loadu_ps(d8.as_ptr());
            let kept = match keep {
                // `|d|`: the sign bit cleared, as `f32::abs`; `<` and `>` false for NaN, as in Rust
                Keep::Within(x_cut) => _mm256_cmp_ps::<_CMP_LT_OQ>(
                    _mm256_and_ps(d, _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX))),
                    _mm256_set1_ps(x_cut),
                ),
                Keep::Fired => _mm256_cmp_ps::<_CMP_GT_OQ>(d, _mm256_setzero_ps()),
            };
            let mask = _mm256_movemask_ps(kept) as usize;
            let perm = _mm256_loadu_si256(PACKED_LANES.0[mask].as_ptr().cast::<__m256i>());
            let packed = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(o8.as_ptr().cast::<__m256i>()), perm);
            _mm256_storeu_si256(slot.as_mut_ptr().cast::<__m256i>(), packed);
            (mask, perm, d)
        };
        if let Some(val) = val.as_deref_mut() {
            let slot: &mut [f32; 8] = (&mut val[end..end + 8]).try_into().expect("eight slots");
            // SAFETY: `slot` is eight f32s (unaligned stores allowed); AVX2.
            unsafe { _mm256_storeu_ps(slot.as_mut_ptr(), _mm256_permutevar8x32_ps(d, perm)) };
        }
        end += mask.count_ones() as usize;
    }
    (end, whole)
}

/// Which of four lanes are above `low`, as a 4-bit mask (lane 0 the lowest bit).
#[inline(always)]
fn lanes_above(x: &[f32; 4], low: f32) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cmpgt_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_set1_ps};
        // SAFETY: SSE is part of x86-64; `x` is four readable f32s (unaligned loads allowed).
        unsafe { _mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(x.as_ptr()), _mm_set1_ps(low))) as usize }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        x.iter().enumerate().fold(0, |m, (j, &x)| m | (usize::from(x > low) << j))
    }
}

/// For each 4-bit mask, the offsets of its set bits packed to the front, and their count.
const PACK4: [([u32; 4], usize); 16] = {
    let mut t = [([0u32; 4], 0usize); 16];
    let mut m = 0;
    while m < 16 {
        let mut k = 0;
        let mut j = 0;
        while j < 4 {
            if m & (1 << j) != 0 {
                t[m].0[k] = j as u32;
                k += 1;
            }
            j += 1;
        }
        t[m].1 = k;
        m += 1;
    }
    t
};

/// `y += a x` entry by entry, eight entries at a time (short rows, such as a readout's 26, would
/// otherwise fall to the scalar remainder of a loop vectorised for 32).
#[inline(always)]
fn axpy(y: &mut [f32], x: &[f32], a: f32) {
    let n = y.len().min(x.len());
    let (mut ys, mut xs) = (y[..n].chunks_exact_mut(8), x[..n].chunks_exact(8));
    for (y, x) in (&mut ys).zip(&mut xs) {
        axpy_width::<8>(y, x, a);
    }
    for (y, x) in ys.into_remainder().iter_mut().zip(xs.remainder()) {
        *y += a * x;
    }
}

/// [`axpy`] over `y`'s first `WIDTH` entries (0: all of `x`), every load before the stores so
/// that the fixed width vectorises without an aliasing check (the same operations).
#[inline(always)]
fn axpy_width<const WIDTH: usize>(y: &mut [f32], x: &[f32], a: f32) {
    if WIDTH == 0 {
        return axpy(y, x, a);
    }
    let (x, y): (&[f32; WIDTH], &mut [f32; WIDTH]) =
        (x[..WIDTH].try_into().expect("WIDTH entries"), (&mut y[..WIDTH]).try_into().expect("WIDTH entries"));
    let mut v = *y;
    for l in 0..WIDTH {
        v[l] += a * x[l];
    }
    *y = v;
}

#[inline(always)]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    debug_assert_eq!(a.len(), b.len(), "a dot product of equal lengths");
    #[cfg(target_arch = "x86_64")]
    return sse_dot(a, b);
    #[cfg(not(target_arch = "x86_64"))]
    portable_dot(a, b)
}

/// [`dot`] in portable code: four running sums, so that the compiler vectorises it, and a tail.
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
#[inline(always)]
fn portable_dot(a: &[f32], b: &[f32]) -> f32 {
    let mut s = [0f32; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            s[l] += x[l] * y[l];
        }
    }
    let mut tail = -0.0f32;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    (s[0] + s[1]) + (s[2] + s[3]) + tail
}

/// [`portable_dot`] with its four running sums in one SSE register (SSE is part of x86-64): the
/// same operations in the same order, so the same to the bit (tested). Left to the compiler, the
/// sums were not kept in one register: it shuffled lanes at each step.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn sse_dot(a: &[f32], b: &[f32]) -> f32 {
    use std::arch::x86_64::{
        _mm_add_ps, _mm_add_ss, _mm_cvtss_f32, _mm_loadu_ps, _mm_movehl_ps, _mm_mul_ps, _mm_setzero_ps, _mm_shuffle_ps,
    };
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    // SAFETY: SSE is part of the x86-64 baseline; each chunk is four readable f32s (unaligned
    // loads allowed).
    let s = unsafe {
        let mut s = _mm_setzero_ps();
        for (x, y) in ca.zip(cb) {
            s = _mm_add_ps(s, _mm_mul_ps(_mm_loadu_ps(x.as_ptr()), _mm_loadu_ps(y.as_ptr())));
        }
        // lane 0: s0 + s1, lane 2: s2 + s3; then their sum
        let t = _mm_add_ps(s, _mm_shuffle_ps::<0b10_11_00_01>(s, s));
        _mm_cvtss_f32(_mm_add_ss(t, _mm_movehl_ps(t, t)))
    };
    let mut tail = -0.0f32;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    s + tail
}

/// Adds input `i`'s fan-out, times `x`, into `u`.
#[inline(always)]
fn scatter(plan: &Plan, w: &[f32], i: usize, x: f32, u: &mut [f32]) {
    let n = plan.n_out;
    match &plan.kernel {
        Kernel::Dense => axpy(u, &w[i * n..][..n], x),
        Kernel::Conv { oc: 8, .. } => conv_scatter::<8>(plan, w, i, x, u),
        Kernel::Conv { oc: 16, .. } => conv_scatter::<16>(plan, w, i, x, u),
        Kernel::Conv { .. } => conv_scatter::<0>(plan, w, i, x, u),
        Kernel::Pool { c, weight, offsets, targets } => {
            let (p, ch) = (i / c, i % c);
            for &q in &targets[offsets[p] as usize..offsets[p + 1] as usize] {
                u[q as usize * c + ch] += weight * x;
            }
        }
    }
}

/// Adds `x` times the gradient `g` of input `i`'s targets into its weights' gradient.
#[inline(always)]
fn weight_grad(plan: &Plan, gw: &mut [f32], i: usize, x: f32, g: &[f32]) {
    let n = plan.n_out;
    match &plan.kernel {
        Kernel::Dense => axpy(&mut gw[i * n..][..n], g, x),
        Kernel::Conv { oc: 8, .. } => conv_weight_grad::<8>(plan, gw, i, x, g),
        Kernel::Conv { oc: 16, .. } => conv_weight_grad::<16>(plan, gw, i, x, g),
        Kernel::Conv { .. } => conv_weight_grad::<0>(plan, gw, i, x, g),
        Kernel::Pool { .. } => {}
    }
}

/// The gradient by input `i`: its weights to its targets against their gradient `g`.
#[inline(always)]
fn gather(plan: &Plan, w: &[f32], i: usize, g: &[f32]) -> f32 {
    let n = plan.n_out;
    match &plan.kernel {
        Kernel::Dense => dot(&w[i * n..][..n], g),
        Kernel::Conv { oc: 8, .. } => conv_gather::<8>(plan, w, i, g),
        Kernel::Conv { oc: 16, .. } => conv_gather::<16>(plan, w, i, g),
        Kernel::Conv { .. } => conv_gather::<0>(plan, w, i, g),
        Kernel::Pool { c, weight, offsets, targets } => {
            let (p, ch) = (i / c, i % c);
            let mut sum = -0.0;
            for &q in &targets[offsets[p] as usize..offsets[p + 1] as usize] {
                sum += weight * g[q as usize * c + ch];
            }
            sum
        }
    }
}

/// A convolution's kernel, its output channels `oc` being `WIDTH` when that is not 0 (the loops
/// then compiled for that many channels, the same operations in the same order).
struct ConvOf<'a> {
    ic: usize,
    oc: usize,
    kk: usize,
    offsets: &'a [u32],
    targets: &'a [(u32, u32)],
}

impl ConvOf<'_> {
    #[inline(always)]
    fn new<const WIDTH: usize>(plan: &Plan) -> ConvOf<'_> {
        let Kernel::Conv { ic, oc, kk, offsets, targets } = &plan.kernel else {
            unreachable!("called for convolutions only");
        };
        ConvOf { ic: *ic, oc: if WIDTH == 0 { *oc } else { WIDTH }, kk: *kk, offsets, targets }
    }

    /// Input `i`'s channel and its targets (output pixel, kernel position).
    #[inline(always)]
    fn targets_of(&self, i: usize) -> (usize, &[(u32, u32)]) {
        // a shift where the channels are a power of two (a division per input costs more than
        // the rest of finding its targets)
        let (p, c) = if self.ic.is_power_of_two() {
            let s = self.ic.trailing_zeros();
            (i >> s, i & (self.ic - 1))
        } else {
            (i / self.ic, i % self.ic)
        };
        (c, &self.targets[self.offsets[p] as usize..self.offsets[p + 1] as usize])
    }
}

/// [`scatter`] for a convolution of `WIDTH` output channels (0: any).
#[inline(always)]
fn conv_scatter<const WIDTH: usize>(plan: &Plan, w: &[f32], i: usize, x: f32, u: &mut [f32]) {
    let conv = ConvOf::new::<WIDTH>(plan);
    let (oc, kk, (c, targets)) = (conv.oc, conv.kk, conv.targets_of(i));
    for &(q, k) in targets {
        axpy_width::<WIDTH>(&mut u[q as usize * oc..][..oc], &w[(c * kk + k as usize) * oc..][..oc], x);
    }
}

/// [`weight_grad`] for a convolution of `WIDTH` output channels (0: any).
#[inline(always)]
fn conv_weight_grad<const WIDTH: usize>(plan: &Plan, gw: &mut [f32], i: usize, x: f32, g: &[f32]) {
    let conv = ConvOf::new::<WIDTH>(plan);
    let (oc, kk, (c, targets)) = (conv.oc, conv.kk, conv.targets_of(i));
    for &(q, k) in targets {
        axpy_width::<WIDTH>(&mut gw[(c * kk + k as usize) * oc..][..oc], &g[q as usize * oc..][..oc], x);
    }
}

/// [`gather`] for a convolution of `WIDTH` output channels (0: any).
#[inline(always)]
fn conv_gather<const WIDTH: usize>(plan: &Plan, w: &[f32], i: usize, g: &[f32]) -> f32 {
    let conv = ConvOf::new::<WIDTH>(plan);
    let (oc, kk, (c, targets)) = (conv.oc, conv.kk, conv.targets_of(i));
    // sums from -0.0, as `Iterator::sum`, in loops rather than closures (which would not be
    // compiled for the caller's AVX2)
    let mut sum = -0.0;
    for &(q, k) in targets {
        sum += dot(&w[(c * kk + k as usize) * oc..][..oc], &g[q as usize * oc..][..oc]);
    }
    sum
}

/// What a worker's backward passes share: the parameters, each layer's weights laid out by input
/// (made once per batch, [`SparseSnn::weights_by_input`]), and buffers for the step-by-step
/// gradients, taken from the pool and given back to it, sample after sample.
struct Workspace<'a> {
    params: &'a Params,
    by_input: &'a [Option<ByInput>],
    pool: &'a mut Vec<Vec<f32>>,
}

/// Lanes of [`gather_all_conv`] and [`gather_all_dense`]: inputs gathered at once.
const GATHER_LANES: usize = 8;

/// A layer's weights laid out for gathering [`GATHER_LANES`] inputs at once.
enum ByInput {
    /// A convolution's, `[k][out_c][in_c]` ([`gather_all_conv`]).
    Conv(Vec<f32>),
    /// A dense layer's, `[out][in]` ([`gather_all_dense`]).
    Dense(Vec<f32>),
}

/// `w` laid out by input ([`ByInput`]): a dense layer's, and a convolution's when its input
/// channels come in whole [`GATHER_LANES`] (else `None`: [`gather`] input by input).
fn weights_by_input(plan: &Plan, w: &[f32]) -> Option<ByInput> {
    if let Kernel::Dense = plan.kernel {
        let n = plan.n_out;
        let n_in = w.len().checked_div(n).unwrap_or(0);
        let mut t = vec![0f32; w.len()];
        for i in 0..n_in {
            for o in 0..n {
                t[o * n_in + i] = w[i * n + o];
            }
        }
        return Some(ByInput::Dense(t));
    }
    let Kernel::Conv { ic, oc, kk, .. } = plan.kernel else {
        return None;
    };
    if ic == 0 || !ic.is_multiple_of(GATHER_LANES) {
        return None;
    }
    let mut t = vec![0f32; ic * kk * oc];
    for c in 0..ic {
        for k in 0..kk {
            for o in 0..oc {
                t[(k * oc + o) * ic + c] = w[(c * kk + k) * oc + o];
            }
        }
    }
    Some(ByInput::Conv(t))
}

/// [`gather`] for every input of a dense layer of `n` outputs (`g_in[i]`, all of them),
/// [`GATHER_LANES`] inputs at a time from `wt` (`[out][in]`). Each lane does the very operations
/// of [`dot`] in its order (four running sums and a tail from -0.0), so the result is the same to
/// the bit (tested).
#[inline(always)]
fn gather_all_dense(wt: &[f32], n: usize, g: &[f32], g_in: &mut [f32]) {
    const L: usize = GATHER_LANES;
    let n_in = g_in.len();
    let full = n / 4 * 4;
    let lanes_end = n_in / L * L;
    let (head, rest) = g_in.split_at_mut(lanes_end);
    for (c0, out) in head.chunks_exact_mut(L).enumerate() {
        let i0 = c0 * L;
        let lanes = |o: usize| -> &[f32; L] { wt[o * n_in + i0..][..L].try_into().expect("L lanes") };
        let mut sums = [[0f32; L]; 4];
        for j in (0..full).step_by(4) {
            for (l, sum) in sums.iter_mut().enumerate() {
                let (w, y) = (lanes(j + l), g[j + l]);
                for c in 0..L {
                    sum[c] += w[c] * y;
                }
            }
        }
        let mut tail = [-0.0f32; L];
        for (o, &y) in g.iter().enumerate().take(n).skip(full) {
            let w = lanes(o);
            for c in 0..L {
                tail[c] += w[c] * y;
            }
        }
        for c in 0..L {
            out[c] = (sums[0][c] + sums[1][c]) + (sums[2][c] + sums[3][c]) + tail[c];
        }
    }
    // the last inputs one by one, as `dot` over their row
    let mut row = if rest.is_empty() { Vec::new() } else { vec![0f32; n] };
    for (j, out) in rest.iter_mut().enumerate() {
        let i = lanes_end + j;
        for (o, r) in row.iter_mut().enumerate() {
            *r = wt[o * n_in + i];
        }
        *out = dot(&row, &g[..n]);
    }
}

/// `x` replaced by the surrogate derivative at `x` (one arm per surrogate, so that each loop
/// vectorises).
#[inline(always)]
fn derivatives_in_place(surrogate: Surrogate, x: &mut [f32]) {
    macro_rules! each {
        ($s:expr) => {
            for x in x.iter_mut() {
                *x = $s.derivative(*x);
            }
        };
    }
    match surrogate {
        Surrogate::FastSigmoid { slope } => each!(Surrogate::FastSigmoid { slope }),
        Surrogate::Arctan { alpha } => each!(Surrogate::Arctan { alpha }),
        Surrogate::Triangle { width } => each!(Surrogate::Triangle { width }),
    }
}

/// `g_u += (g_out + g_rec) sigma'` over every neuron, eight at a time (the operations of the
/// listed neurons' update, `g_out * 1 + g_rec` being `g_out + g_rec`).
#[inline(always)]
fn surrogate_all(g_u: &mut [f32], sv: &[f32], go: &[f32], gr: &[f32]) {
    const L: usize = 8;
    let n = g_u.len();
    let (sv, go, gr) = (&sv[..n], &go[..n], &gr[..n]);
    let full = n / L * L;
    for (((g, s), go), gr) in
        g_u.chunks_exact_mut(L).zip(sv.chunks_exact(L)).zip(go.chunks_exact(L)).zip(gr.chunks_exact(L))
    {
        for c in 0..L {
            g[c] += (go[c] + gr[c]) * s[c];
        }
    }
    for o in full..n {
        g_u[o] += (go[o] + gr[o]) * sv[o];
    }
}

/// [`gather`] for every input of a convolution (`g_in[i]`, all of them), a pixel's input channels
/// [`GATHER_LANES`] at a time from `wt` ([`weights_by_input`]). Each lane does the very
/// operations of [`gather`] in its order (the products of [`dot`] in four running sums and a tail,
/// the targets summed from -0.0), so the result is the same to the bit (tested).
#[inline(always)]
fn gather_all_conv(plan: &Plan, wt: &[f32], g: &[f32], g_in: &mut [f32]) {
    const L: usize = GATHER_LANES;
    let Kernel::Conv { ic, oc, offsets, targets, .. } = &plan.kernel else {
        unreachable!("gather_all_conv on a convolution only");
    };
    let (ic, oc) = (*ic, *oc);
    let full = oc / 4 * 4;
    for (p, out) in g_in.chunks_exact_mut(ic).enumerate() {
        let list = &targets[offsets[p] as usize..offsets[p + 1] as usize];
        for (c0, out) in out.chunks_exact_mut(L).enumerate() {
            let c0 = c0 * L;
            let mut acc = [-0.0f32; L];
            for &(q, k) in list {
                let gq = &g[q as usize * oc..][..oc];
                let lanes =
                    |o: usize| -> &[f32; L] { wt[(k as usize * oc + o) * ic + c0..][..L].try_into().expect("L lanes") };
                let mut sums = [[0f32; L]; 4];
                for j in (0..full).step_by(4) {
                    for (l, sum) in sums.iter_mut().enumerate() {
                        let (w, y) = (lanes(j + l), gq[j + l]);
                        for c in 0..L {
                            sum[c] += w[c] * y;
                        }
                    }
                }
                let mut tail = [-0.0f32; L];
                for (o, &y) in gq.iter().enumerate().skip(full) {
                    let w = lanes(o);
                    for c in 0..L {
                        tail[c] += w[c] * y;
                    }
                }
                for c in 0..L {
                    acc[c] += (sums[0][c] + sums[1][c]) + (sums[2][c] + sums[3][c]) + tail[c];
                }
            }
            out.copy_from_slice(&acc);
        }
    }
}

/// Adam (AdamW with a weight decay), with each tensor's gradient norm clipped, as burn's
/// `AdamConfig` / `AdamWConfig` with their defaults (betas 0.9 and 0.999, epsilon 1e-5).
#[derive(Debug, Clone)]
pub struct Adam {
    pub weight_decay: f32,
    /// 0: no clipping.
    pub clip_norm: f32,
    /// L2-SP (Li et al., ICML 2018, "Explicit inductive bias for transfer learning with
    /// convolutional networks"), decoupled as AdamW decouples its decay: every step pulls each
    /// weight toward its value in these starting weights by `lr * strength * (w - w0)`.
    pub anchor: Option<(Params, f32)>,
    /// Layers whose tensors stay as they started (true: frozen), by layer index.
    pub frozen: Vec<bool>,
    m: Params,
    v: Params,
    time: i32,
}

impl Adam {
    pub fn new(params: &Params, weight_decay: f32, clip_norm: f32) -> Adam {
        Adam {
            weight_decay,
            clip_norm,
            anchor: None,
            frozen: Vec::new(),
            m: params.zeros_like(),
            v: params.zeros_like(),
            time: 0,
        }
    }

    /// Pulls the weights toward `start` with `strength` per unit of learning rate (L2-SP; 0: off).
    pub fn with_anchor(mut self, start: &Params, strength: f32) -> Adam {
        self.anchor = (strength > 0.0).then(|| (start.clone(), strength));
        self
    }

    /// Keeps the layers marked true as they are.
    pub fn with_frozen(mut self, frozen: Vec<bool>) -> Adam {
        self.frozen = frozen;
        self
    }

    /// Forgets the moments, as a new optimiser would (the anchor and frozen layers kept).
    pub fn restart(&mut self) {
        self.m = self.m.zeros_like();
        self.v = self.v.zeros_like();
        self.time = 0;
    }

    /// One step of `lr` along `grads`.
    pub fn step(&mut self, params: &mut Params, grads: &Params, lr: f64) {
        const B1: f32 = 0.9;
        const B2: f32 = 0.999;
        const EPS: f32 = 1e-5;
        self.time += 1;
        let bc2 = (1.0 - B2.powi(self.time)).sqrt();
        let factor = bc2 / (1.0 - B1.powi(self.time));
        let decay = 1.0 - (lr * self.weight_decay as f64) as f32;
        // at most all the way back (a larger pull would overshoot the start)
        let pull = self.anchor.as_ref().map(|(_, s)| ((lr * *s as f64) as f32).min(1.0));
        let lr = lr as f32;
        for (l, (((layer, g), m), v)) in
            params.layers.iter_mut().zip(&grads.layers).zip(&mut self.m.layers).zip(&mut self.v.layers).enumerate()
        {
            if self.frozen.get(l).copied().unwrap_or(false) {
                continue;
            }
            let anchor = self.anchor.as_ref().map(|(a, _)| a.layers[l].all());
            for (k, (((p, g), m), v)) in
                layer.all_mut().into_iter().zip(g.all()).zip(m.all_mut()).zip(v.all_mut()).enumerate()
            {
                let clip = if self.clip_norm > 0.0 {
                    let norm = g.iter().map(|g| g * g).sum::<f32>().sqrt();
                    (self.clip_norm / (norm + f32::MIN_POSITIVE)).min(1.0)
                } else {
                    1.0
                };
                for (((p, &g), m), v) in p.iter_mut().zip(g).zip(m.iter_mut()).zip(v.iter_mut()) {
                    let g = g * clip;
                    *m = *m * B1 + g * (1.0 - B1);
                    *v = *v * B2 + g * g * (1.0 - B2);
                    let delta = *m * factor / (v.sqrt() + EPS * bc2);
                    if self.weight_decay > 0.0 {
                        *p *= decay;
                    }
                    *p -= lr * delta;
                }
                if let (Some(pull), Some(a)) = (pull, &anchor) {
                    p.iter_mut().zip(a[k]).for_each(|(p, &a)| *p = a + (1.0 - pull) * (*p - a));
                }
            }
        }
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
