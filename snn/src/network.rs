//! Networks as a chain of layers, each a linear operation optionally followed by neurons, and
//! the time-stepped (dense) reference forward pass that the event-driven engine must reproduce.
//!
//! Neuron indices are C-order over each layer's shape (`[channel][row][col]`). Weights are stored
//! as PyTorch and NIR store them: dense `[out][in]`, convolution `[out][in][kh][kw]`.

use crate::error::{Error, Result};
use crate::neuron::NeuronParams;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PoolKind {
    Sum,
    Avg,
}

/// A linear operation between populations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Op {
    Dense {
        n_in: usize,
        n_out: usize,
        weight: Vec<f32>,
        bias: Option<Vec<f32>>,
    },
    Conv2d {
        in_shape: [usize; 3],
        out_channels: usize,
        kernel: [usize; 2],
        stride: [usize; 2],
        padding: [usize; 2],
        weight: Vec<f32>,
        bias: Option<Vec<f32>>,
    },
    Pool {
        kind: PoolKind,
        in_shape: [usize; 3],
        kernel: [usize; 2],
        stride: [usize; 2],
    },
}

impl Op {
    pub fn n_in(&self) -> usize {
        match self {
            Op::Dense { n_in, .. } => *n_in,
            Op::Conv2d { in_shape, .. } | Op::Pool { in_shape, .. } => in_shape.iter().product(),
        }
    }

    /// Output shape: `[n]` for dense, `[c, h, w]` otherwise.
    pub fn out_shape(&self) -> Vec<usize> {
        match self {
            Op::Dense { n_out, .. } => vec![*n_out],
            Op::Conv2d { in_shape, out_channels, kernel, stride, padding, .. } => {
                let o = |d: usize| (in_shape[d + 1] + 2 * padding[d] - kernel[d]) / stride[d] + 1;
                vec![*out_channels, o(0), o(1)]
            }
            Op::Pool { in_shape, kernel, stride, .. } => {
                let o = |d: usize| (in_shape[d + 1] - kernel[d]) / stride[d] + 1;
                vec![in_shape[0], o(0), o(1)]
            }
        }
    }

    pub fn n_out(&self) -> usize {
        self.out_shape().iter().product()
    }

    pub fn bias(&self) -> Option<&[f32]> {
        match self {
            Op::Dense { bias, .. } | Op::Conv2d { bias, .. } => bias.as_deref(),
            Op::Pool { .. } => None,
        }
    }

    fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::network(m));
        match self {
            Op::Dense { n_in, n_out, weight, bias } => {
                if weight.len() != n_in * n_out {
                    return bad(format!("dense {n_in}->{n_out} has {} weights", weight.len()));
                }
                if bias.as_ref().is_some_and(|b| b.len() != *n_out) {
                    return bad(format!("dense {n_in}->{n_out} has a bias of another length"));
                }
            }
            Op::Conv2d { in_shape, out_channels, kernel, stride, padding, weight, bias } => {
                if stride.contains(&0) || kernel.contains(&0) {
                    return bad("conv2d needs positive kernel and stride".into());
                }
                if (0..2).any(|d| in_shape[d + 1] + 2 * padding[d] < kernel[d]) {
                    return bad(format!("conv2d kernel {kernel:?} larger than its padded input {in_shape:?}"));
                }
                if weight.len() != out_channels * in_shape[0] * kernel[0] * kernel[1] {
                    return bad(format!(
                        "conv2d has {} weights, its shape needs {}",
                        weight.len(),
                        out_channels * in_shape[0] * kernel[0] * kernel[1]
                    ));
                }
                if bias.as_ref().is_some_and(|b| b.len() != *out_channels) {
                    return bad("conv2d bias length differs from its output channels".into());
                }
            }
            Op::Pool { in_shape, kernel, stride, .. } => {
                if stride.contains(&0) || kernel.contains(&0) || (0..2).any(|d| in_shape[d + 1] < kernel[d]) {
                    return bad(format!("pool kernel {kernel:?} stride {stride:?} does not fit {in_shape:?}"));
                }
            }
        }
        Ok(())
    }

    /// Adds `x * w` for every output that input `i` reaches into `out` (C-order), in the order
    /// the engine uses, and returns the number of synaptic operations.
    pub fn accumulate(&self, i: usize, x: f32, out: &mut [f32]) -> usize {
        let mut n = 0;
        self.fan_out(i, |o, w| {
            out[o] += x * w;
            n += 1;
        });
        n
    }

    /// Calls `f(output, weight)` for every output input `i` reaches, outputs ascending within each
    /// channel group.
    pub fn fan_out(&self, i: usize, mut f: impl FnMut(usize, f32)) {
        match self {
            Op::Dense { n_in, n_out, weight, .. } => {
                for o in 0..*n_out {
                    f(o, weight[o * n_in + i]);
                }
            }
            Op::Conv2d { in_shape, out_channels, kernel, stride, padding, weight, .. } => {
                let [ic_n, h, w] = *in_shape;
                let (c, y, x) = (i / (h * w), (i / w) % h, i % w);
                let shape = self.out_shape();
                let (oh, ow) = (shape[1], shape[2]);
                for oc in 0..*out_channels {
                    for ky in 0..kernel[0] {
                        let ty = y + padding[0];
                        if ty < ky || (ty - ky) % stride[0] != 0 || (ty - ky) / stride[0] >= oh {
                            continue;
                        }
                        let oy = (ty - ky) / stride[0];
                        for kx in 0..kernel[1] {
                            let tx = x + padding[1];
                            if tx < kx || (tx - kx) % stride[1] != 0 || (tx - kx) / stride[1] >= ow {
                                continue;
                            }
                            let ox = (tx - kx) / stride[1];
                            f((oc * oh + oy) * ow + ox, weight[((oc * ic_n + c) * kernel[0] + ky) * kernel[1] + kx]);
                        }
                    }
                }
            }
            Op::Pool { kind, in_shape, kernel, stride } => {
                let [_, h, w] = *in_shape;
                let (c, y, x) = (i / (h * w), (i / w) % h, i % w);
                let shape = self.out_shape();
                let (oh, ow) = (shape[1], shape[2]);
                let wgt = match kind {
                    PoolKind::Sum => 1.0,
                    PoolKind::Avg => 1.0 / (kernel[0] * kernel[1]) as f32,
                };
                for oy in
                    y.saturating_sub(kernel[0] - 1).div_ceil(stride[0])..=(y / stride[0]).min(oh.saturating_sub(1))
                {
                    if y < oy * stride[0] || y >= oy * stride[0] + kernel[0] {
                        continue;
                    }
                    for ox in
                        x.saturating_sub(kernel[1] - 1).div_ceil(stride[1])..=(x / stride[1]).min(ow.saturating_sub(1))
                    {
                        if x < ox * stride[1] || x >= ox * stride[1] + kernel[1] {
                            continue;
                        }
                        f((c * oh + oy) * ow + ox, wgt);
                    }
                }
            }
        }
    }
}

/// A linear operation, then (optionally) a population of spiking neurons with an optional
/// recurrent dense connection (delayed by one step).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Layer {
    pub op: Op,
    /// `None`: the op's output passes on as values (for example a pooling before a convolution).
    pub neurons: Option<NeuronParams>,
    /// `[n][n]` recurrent weights, from the layer's spikes at `t - 1` to its input at `t`.
    pub recurrent: Option<Vec<f32>>,
    /// A bias of the recurrent connection (NIR's `Affine` on the recurrent edge): added with the
    /// recurrent input, so from `t = 1` on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recurrent_bias: Option<Vec<f32>>,
}

/// A feed-forward chain of layers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Network {
    pub input_shape: Vec<usize>,
    pub layers: Vec<Layer>,
}

impl Network {
    pub fn new(input_shape: Vec<usize>, layers: Vec<Layer>) -> Result<Network> {
        let net = Network { input_shape, layers };
        net.validate()?;
        Ok(net)
    }

    pub fn n_inputs(&self) -> usize {
        self.input_shape.iter().product()
    }

    pub fn n_outputs(&self) -> usize {
        self.layers.last().map_or(self.n_inputs(), |l| l.op.n_out())
    }

    pub fn validate(&self) -> Result<()> {
        if self.layers.is_empty() {
            return Err(Error::network("a network needs at least one layer"));
        }
        let mut n = self.n_inputs();
        for (k, l) in self.layers.iter().enumerate() {
            l.op.validate().map_err(|e| Error::layer(k, format!("{e}")))?;
            if l.op.n_in() != n {
                return Err(Error::network(format!(
                    "layer {k} takes {} inputs, the previous layer gives {n}",
                    l.op.n_in()
                )));
            }
            n = l.op.n_out();
            if let Some(r) = &l.recurrent
                && (r.len() != n * n || l.neurons.is_none())
            {
                return Err(Error::layer(k, format!("recurrent weights need neurons and {n}x{n} values")));
            }
            if let Some(b) = &l.recurrent_bias
                && (b.len() != n || l.recurrent.is_none() || b.iter().any(|v| !v.is_finite()))
            {
                return Err(Error::layer(k, format!("a recurrent bias needs recurrent weights and {n} finite values")));
            }
            if let Some(p) = &l.neurons
                && p.kind == crate::neuron::NeuronKind::Li
                && (k + 1 != self.layers.len() || matches!(l.op, Op::Conv2d { .. }) || l.recurrent.is_some())
            {
                return Err(Error::layer(
                    k,
                    "leaky integrators (non-spiking) are a readout: the last layer, dense or pooled, not recurrent",
                ));
            }
            if let Some(p) = &l.neurons {
                let finite = [p.alpha, p.beta, p.v_th, p.v_reset, p.v_leak].iter().all(|v| v.is_finite());
                if !finite || !(0.0..=1.0).contains(&p.beta) || !(0.0..=1.0).contains(&p.alpha) {
                    return Err(Error::layer(k, format!("neuron parameters out of range: {p:?}")));
                }
            }
            let weights: &[f32] = match &l.op {
                Op::Dense { weight, .. } | Op::Conv2d { weight, .. } => weight,
                Op::Pool { .. } => &[],
            };
            if let Some(i) = weights.iter().chain(l.op.bias().unwrap_or(&[])).position(|w| !w.is_finite()) {
                return Err(Error::layer(k, format!("weight {i} is not finite")));
            }
        }
        Ok(())
    }
}

/// What a time-stepped run produced.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Record {
    /// Per layer, per step: indices of the neurons that spiked (ascending; empty for layers
    /// without neurons).
    pub spikes: Vec<Vec<Vec<u32>>>,
    /// Per layer, the membrane after the last step.
    pub v: Vec<Vec<f32>>,
    /// A leaky-integrator output layer's readout: `max(0, highest membrane over the steps)`.
    pub v_max: Vec<f32>,
}

impl Record {
    /// Spike counts of the last layer, per neuron.
    pub fn output_counts(&self, n: usize) -> Vec<u32> {
        let mut c = vec![0u32; n];
        if let Some(last) = self.spikes.last() {
            for step in last {
                for &i in step {
                    c[i as usize] += 1;
                }
            }
        }
        c
    }
}

/// A dense layer's weights (`[n_out][n_in]`, as [`Op::Dense`] holds them) by input: each input's
/// `n_out` weights contiguous and padded with zeros to `stride`, the next multiple of `block`, so
/// that a run of `block` outputs can be read from any row; returns the weights and the stride.
pub(crate) fn dense_by_input(n_in: usize, n_out: usize, weight: &[f32], block: usize) -> (Vec<f32>, usize) {
    let stride = n_out.div_ceil(block) * block;
    let mut t = vec![0f32; n_in * stride];
    for o in 0..n_out {
        for i in 0..n_in {
            t[i * stride + o] = weight[o * n_in + i];
        }
    }
    (t, stride)
}

/// The time-stepped reference: every neuron, every step, dense sums over all inputs (in ascending
/// input order). `input` holds `steps` rows of `n_inputs` values.
pub fn forward_dense(net: &Network, input: &[f32], steps: usize) -> Result<Record> {
    forward(net, input, steps, None)
}

/// Every layer's membrane and synaptic current after every step (`[layer][step * n + neuron]`),
/// for comparing dynamics with other simulators.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    pub v: Vec<Vec<f32>>,
    pub i: Vec<Vec<f32>>,
}

/// [`forward_dense`], also recording a [`Trace`].
pub fn forward_dense_traced(net: &Network, input: &[f32], steps: usize) -> Result<(Record, Trace)> {
    let mut trace = Trace { v: vec![Vec::new(); net.layers.len()], i: vec![Vec::new(); net.layers.len()] };
    let r = forward(net, input, steps, Some(&mut trace))?;
    Ok((r, trace))
}

fn forward(net: &Network, input: &[f32], steps: usize, mut trace: Option<&mut Trace>) -> Result<Record> {
    let n_in = net.n_inputs();
    if input.len() != steps * n_in {
        return Err(Error::input(format!("{} input values are not {steps} steps of {n_in}", input.len())));
    }
    let mut v: Vec<Vec<f32>> = net.layers.iter().map(|l| vec![0.0; l.op.n_out()]).collect();
    let mut cur: Vec<Vec<f32>> = v.clone();
    let mut prev_spikes: Vec<Vec<f32>> = v.clone();
    let mut record = Record { spikes: vec![Vec::with_capacity(steps); net.layers.len()], ..Record::default() };
    let last = net.layers.len() - 1;
    if net.layers[last].neurons.is_some_and(|p| p.kind == crate::neuron::NeuronKind::Li) {
        record.v_max = vec![0.0; net.layers[last].op.n_out()];
    }
    for t in 0..steps {
        let mut x: Vec<f32> = input[t * n_in..(t + 1) * n_in].to_vec();
        for (k, layer) in net.layers.iter().enumerate() {
            let n = layer.op.n_out();
            let mut acc = vec![0.0f32; n];
            for (i, &xi) in x.iter().enumerate() {
                layer.op.accumulate(i, xi, &mut acc);
            }
            if let Some(b) = layer.op.bias() {
                // one bias per output channel (a convolution's covers its whole plane)
                let plane = n / b.len();
                for (j, a) in acc.iter_mut().enumerate() {
                    *a += b[j / plane];
                }
            }
            // The recurrent input is summed on its own (as NIR sums incoming edges) and is absent
            // at t = 0.
            if let (Some(w), true) = (&layer.recurrent, t > 0) {
                let mut rec = vec![0.0f32; n];
                for (i, &s) in prev_spikes[k].iter().enumerate() {
                    if s != 0.0 {
                        for (o, r) in rec.iter_mut().enumerate() {
                            *r += s * w[o * n + i];
                        }
                    }
                }
                if let Some(b) = &layer.recurrent_bias {
                    for (r, b) in rec.iter_mut().zip(b) {
                        *r += b;
                    }
                }
                for (a, r) in acc.iter_mut().zip(&rec) {
                    *a += r;
                }
            }
            match &layer.neurons {
                None => x = acc,
                Some(p) => {
                    let mut out = vec![0.0f32; n];
                    let mut fired = Vec::new();
                    for j in 0..n {
                        if p.step(&mut cur[k][j], &mut v[k][j], acc[j]) {
                            out[j] = 1.0;
                            fired.push(j as u32);
                        }
                    }
                    if let Some(tr) = trace.as_deref_mut() {
                        tr.v[k].extend_from_slice(&v[k]);
                        tr.i[k].extend_from_slice(&cur[k]);
                    }
                    if k == last && !record.v_max.is_empty() {
                        for (m, &vj) in record.v_max.iter_mut().zip(&v[k]) {
                            *m = m.max(vj);
                        }
                    }
                    record.spikes[k].push(fired);
                    prev_spikes[k] = out.clone();
                    x = out;
                }
            }
        }
    }
    record.v = v;
    Ok(record)
}

/// Uniform weights in `+-gain / sqrt(fan_in)` (PyTorch's default scale), from `seed`.
fn uniform(rng: &mut ChaCha8Rng, n: usize, fan_in: usize, gain: f32) -> Vec<f32> {
    let bound = gain / (fan_in as f32).sqrt();
    (0..n).map(|_| rng.random_range(-bound..bound)).collect()
}

/// The peer benchmark's weight scale: the peers' work per sample (about 330 k synaptic events).
pub const PEER_GAIN: f32 = 7.5;
/// The peer benchmark's steps per sample, and the step.
pub const PEER_STEPS: usize = 20;
pub const PEER_DT_US: i64 = 1_000;
/// The peer benchmark's input shape, `[channels, height, width]`.
pub const PEER_INPUT: [usize; 3] = [2, 60, 80];

/// Input events `(t_us, input)` of one peer-benchmark sample, in time order: each input spikes
/// with probability 0.75% per step, 10 us into the step. Seeded.
pub fn peer_sample(seed: u64, n_inputs: usize) -> Vec<(i64, u32)> {
    let x = random_input(seed, PEER_STEPS, n_inputs, 0.0075);
    let mut ev = Vec::new();
    for t in 0..PEER_STEPS {
        for i in 0..n_inputs {
            if x[t * n_inputs + i] != 0.0 {
                ev.push((t as i64 * PEER_DT_US + 10, i as u32));
            }
        }
    }
    ev
}

/// The peer benchmark's convolutional SNN (snnTorch, Norse and PyTorch in the shared benchmark):
/// 2x60x80 ON/OFF input, conv 5x5 stride 2 to 8 channels, LIF, conv 3x3 stride 2 to 16, LIF,
/// flatten (3744), dense to 26, LIF; LIF with beta 0.9, threshold 1, reset to zero. Bias-free,
/// as neuromorphic chips want; weights seeded, scaled by `gain`.
pub fn peers_conv(seed: u64, gain: f32) -> Network {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let lif = Some(NeuronParams::lif(0.9));
    let conv1 = Op::Conv2d {
        in_shape: [2, 60, 80],
        out_channels: 8,
        kernel: [5, 5],
        stride: [2, 2],
        padding: [0, 0],
        weight: uniform(&mut rng, 8 * 2 * 25, 2 * 25, gain),
        bias: None,
    };
    let conv2 = Op::Conv2d {
        in_shape: [8, 28, 38],
        out_channels: 16,
        kernel: [3, 3],
        stride: [2, 2],
        padding: [0, 0],
        weight: uniform(&mut rng, 16 * 8 * 9, 8 * 9, gain),
        bias: None,
    };
    let dense = Op::Dense { n_in: 3744, n_out: 26, weight: uniform(&mut rng, 26 * 3744, 3744, gain), bias: None };
    let layers = vec![
        Layer { op: conv1, neurons: lif, recurrent: None, recurrent_bias: None },
        Layer { op: conv2, neurons: lif, recurrent: None, recurrent_bias: None },
        Layer { op: dense, neurons: lif, recurrent: None, recurrent_bias: None },
    ];
    Network { input_shape: vec![2, 60, 80], layers }
}

/// Random sparse binary input: each of `n` inputs active with probability `p` at each of `steps`
/// steps, as `steps x n` values.
pub fn random_input(seed: u64, steps: usize, n: usize, p: f64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..steps * n).map(|_| if rng.random_bool(p) { 1.0 } else { 0.0 }).collect()
}
