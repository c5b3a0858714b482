//! Loihi 2 as Lava computes its fixed-point LIF (PyPI `lava-nc` 0.10.0: `proc/lif/models.py`
//! `PyLifModelBitAcc`, `proc/dense/models.py` `PyDenseModelBitAcc`, `utils/weightutils.py`), the
//! models Lava tags `bit_accurate_loihi`. A network is a chain of layers, each a `Dense` synapse
//! block (a convolution written out as one, its shared weights repeated) into LIF neurons, plus an
//! optional recurrent `Dense` block from the layer's spikes to itself. Per step `t`:
//!
//! 1. every synapse block sends what it accumulated at `t - 1` (Lava's `a_buff`: a block delays
//!    by one step, so a chain of `L` layers answers `L` steps after its input):
//!    `a = (sum of w over the inputs that spiked) << weight_exp` (`>>` for a negative exponent,
//!    flooring); input events are graded spikes, their count multiplying the weight;
//! 2. every neuron: `u = trunc(u * (4096 - du - 1) / 4096) + (a << 6)`, wrapped at 24 bits as
//!    Lava wraps it; `v = clip(trunc(v * (4096 - dv) / 4096) + u + bias, +-(2^23 - 1))`, where
//!    `trunc` rounds towards zero (Lava's `sign(x) * (|x| >> 12)`) and `bias = bias_mant <<
//!    bias_exp`; a spike if `v > vth << 6`, then `v = 0` (one spike per step at most);
//! 3. the spikes reach the next layer's and the recurrent block's accumulators, for `t + 1`.
//!
//! Weights are Lava's `weights` after its mixed-sign handling: even integers in `[-256, 254]`
//! (8 bits, scaled by 2: `clip_weights` then `truncate_weights` with 8 weight bits), with one
//! exponent per block; `u` and `v` are 24-bit; `du`, `dv` 12-bit; `vth` 17-bit unsigned;
//! `bias_mant` 13-bit signed, `bias_exp` 0..=7.
//!
//! The event-driven run ([`Run::EventDriven`]) updates only neurons with a non-zero state or input
//! in the step (every neuron of a biased layer, and of the output layer); a neuron at rest without
//! input stays at rest and silent, so it is the stepped run bit for bit (tested).
//!
//! [`map`] quantises a trained network into these formats, naming each [`Approximation`]. Sum
//! pooling between layers folds into the next block's synapses (each spike reaches its window's
//! weights: the same weights, nothing summed), as a pooled input would on the chip.

use super::speck::CoreOp;
use super::xylo::Run;
use super::{Chip, ChipReset, DecayArithmetic, NumberFormat};
use crate::error::{Error, Result};
use crate::model_file::Readout;
use crate::network::{Network, Op, PoolKind};
use crate::neuron::{NeuronKind, NeuronParams, Reset};
use serde::{Deserialize, Serialize};

/// Loihi 2's number formats, as Lava's bit-accurate models compute them.
pub const FORMAT: NumberFormat = NumberFormat {
    weight_bits: 8,
    max_weight_shift: MAX_WEIGHT_EXP as u8,
    state_bits: STATE_BITS,
    threshold_bits: 17,
    decay: DecayArithmetic::Multiply { bits: DECAY_BITS },
    reset: ChipReset::Zero,
    max_spikes_per_step: Some(1),
    max_output_spikes_per_step: Some(1),
    max_input_events_per_step: None,
    source: "Lava 0.10.0 (PyPI lava-nc): proc/lif/models.py PyLifModelBitAcc (u, v 24 bits; du, dv 12 bits with ds_offset 1; vth 17 bits << 6; activation << 6; bias_mant 13 bits << bias_exp), proc/dense/models.py PyDenseModelBitAcc (8-bit weights, mixed sign scaled by 2, << weight_exp, one step's delay), utils/weightutils.py",
};

/// `u`, `v`: 24-bit signed.
pub const STATE_BITS: u8 = 24;
/// `du`, `dv`: 12-bit; a decay is `x * (4096 - d) >> 12`.
pub const DECAY_BITS: u8 = 12;
/// The synaptic input and the threshold are shifted left by 6 bits into the state (Lava's
/// `act_shift`, `vth_shift`).
pub const STATE_SHIFT: u32 = 6;
/// The largest `vth` (17 bits unsigned).
pub const VTH_MAX: u32 = (1 << 17) - 1;
/// The weight exponents taken: Loihi 2's synapse exponent range (lava-dl's `netx` writes
/// `-8..=7`).
pub const MIN_WEIGHT_EXP: i8 = -8;
pub const MAX_WEIGHT_EXP: i8 = 7;
/// `bias_mant`: 13-bit signed; `bias_exp`: 3-bit unsigned.
pub const BIAS_MANT_MAX: i32 = (1 << 12) - 1;
pub const BIAS_EXP_MAX: u8 = 7;
/// The mapper's ceiling on thresholds, in bits: `vth` in `(2^9, 2^10]` where the weights allow,
/// 10 bits of resolution under a threshold and 7 bits (128 thresholds) of the 24-bit state above
/// it (the state is `vth << 6` at the threshold). Set by that arithmetic, not tuned on any data.
pub const THRESHOLD_BITS: u8 = 10;

const DECAY_UNITY: i64 = 1 << DECAY_BITS;
const STATE_MAX: i64 = 1 << (STATE_BITS - 1);

/// A layer in Lava's terms: the synapse block from the layer before (a [`CoreOp`] over the
/// pooled input), its LIF neurons, an optional recurrent block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Loihi2Layer {
    /// The previous layer's neurons (the network's input for the first), `[c, h, w]`.
    pub in_shape: [usize; 3],
    /// Sum pooling of the input folded into the synapses, `pool x pool`, stride `pool` (1: none).
    pub pool: usize,
    /// The synapses over the pooled input (PyTorch's weight layout).
    pub op: CoreOp,
    /// Lava's `weights` values in the op's layout: even, in `[-256, 254]`.
    pub weights: Vec<i16>,
    pub weight_exp: i8,
    /// `[post][pre]` recurrent weights, in the same format.
    pub recurrent: Option<Vec<i16>>,
    pub recurrent_weight_exp: i8,
    pub du: u16,
    pub dv: u16,
    pub vth: u32,
    /// Per neuron (empty: no bias).
    pub bias_mant: Vec<i16>,
    pub bias_exp: Vec<u8>,
    /// Chip units of the synaptic input (`a`) per unit of the float network's state.
    pub scale: f32,
}

impl Loihi2Layer {
    /// The pooled input the synapses see.
    pub fn pooled_shape(&self) -> [usize; 3] {
        let [c, h, w] = self.in_shape;
        [c, h / self.pool, w / self.pool]
    }

    /// The neurons' shape.
    pub fn neuron_shape(&self) -> [usize; 3] {
        self.op.neuron_shape(self.pooled_shape())
    }

    pub fn n_neurons(&self) -> usize {
        self.neuron_shape().iter().product()
    }
}

/// A network in Loihi 2's formats, read out as `readout`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Loihi2Spec {
    pub layers: Vec<Loihi2Layer>,
    pub readout: Readout,
}

/// Something of the float network Loihi 2 computes otherwise, and what the mapping made of it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Approximation {
    /// A decay per step rounded to 12 bits.
    Decay { layer: usize, state: &'static str, float: f32, chip: f32 },
    /// Reset by subtraction becomes Lava's reset to zero.
    ResetToZero { layer: usize },
    /// Every synapse block delays by one step: the output answers `layers` steps after the input,
    /// and a sample runs that many more steps without input.
    Latency { layers: usize },
    /// A CubaLIF layer's bias enters the membrane (Loihi's bias) at the value its current reaches
    /// in the steady state, `b / (1 - alpha)`.
    BiasIntoMembrane { layer: usize },
    /// Weights beyond 8 bits at the largest exponent saturate.
    WeightsSaturated { layer: usize, count: usize },
}

impl std::fmt::Display for Approximation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Approximation::Decay { layer, state, float, chip } => {
                write!(f, "layer {layer}: {state} decay {float:.5} per step becomes {chip:.5} (12 bits)")
            }
            Approximation::ResetToZero { layer } => {
                write!(f, "layer {layer}: reset by subtraction becomes reset to zero")
            }
            Approximation::Latency { layers } => write!(
                f,
                "each of the {layers} synapse blocks delays by one step: a sample runs {layers} more steps without input"
            ),
            Approximation::BiasIntoMembrane { layer } => {
                write!(f, "layer {layer}: the bias enters the membrane at its steady-state current b / (1 - alpha)")
            }
            Approximation::WeightsSaturated { layer, count } => {
                write!(f, "layer {layer}: {count} weights saturate at 8 bits")
            }
        }
    }
}

/// A mapped network and what the mapping changed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Mapped {
    pub spec: Loihi2Spec,
    pub approximations: Vec<Approximation>,
}

fn cannot(layer: Option<usize>, what: impl Into<String>) -> Error {
    Error::Chip { chip: Chip::Loihi2, layer, what: what.into() }
}

/// Lava's `du` for a current decay per step (`alpha = 1 - (du + 1) / 4096`), within 0..=4095.
pub fn du_of(alpha: f32) -> u16 {
    (((1.0 - alpha as f64) * DECAY_UNITY as f64).round() - 1.0).clamp(0.0, 4095.0) as u16
}

/// Lava's `dv` for a membrane decay per step (`beta = 1 - dv / 4096`), within 0..=4095.
pub fn dv_of(beta: f32) -> u16 {
    ((1.0 - beta as f64) * DECAY_UNITY as f64).round().clamp(0.0, 4095.0) as u16
}

/// `p` with Loihi 2's decays (12 bits) and reset to zero: a float network of these neurons leaks
/// and resets as the chip does.
pub fn neurons(p: NeuronParams) -> NeuronParams {
    let mut q = p;
    if p.kind == NeuronKind::CubaLif {
        q.alpha = 1.0 - (du_of(p.alpha) as f32 + 1.0) / DECAY_UNITY as f32;
    }
    if matches!(p.kind, NeuronKind::CubaLif | NeuronKind::Lif | NeuronKind::Li) {
        q.beta = 1.0 - dv_of(p.beta) as f32 / DECAY_UNITY as f32;
    }
    if p.kind != NeuronKind::Li {
        q.reset = Reset::Zero;
    }
    q
}

/// The smallest weight exponent whose 8 bits hold `max_scaled` (the largest weight magnitude in
/// chip input units): `2 * 127 * 2^e >= max_scaled`, within the exponents taken.
pub fn weight_exp_for(max_scaled: f64) -> i8 {
    let mut e = MIN_WEIGHT_EXP;
    while e < MAX_WEIGHT_EXP && 254.0 * 2f64.powi(e as i32) < max_scaled {
        e += 1;
    }
    e
}

/// A block's weights at `scale` (chip input units per float unit) with the smallest exponent
/// that holds the largest of them in 8 bits: Lava's values (even, `2 * m` for an 8-bit `m`), the
/// exponent, and how many saturated.
fn quantise_block(w: &[f32], scale: f32) -> (Vec<i16>, i8, usize) {
    let max = w.iter().fold(0f32, |m, x| m.max(x.abs())) as f64 * scale as f64;
    let e = weight_exp_for(max);
    let unit = 2.0 * 2f64.powi(e as i32);
    let mut saturated = 0;
    let q = w
        .iter()
        .map(|&x| {
            let m = (x as f64 * scale as f64 / unit).round();
            if !(-128.0..=127.0).contains(&m) {
                saturated += 1;
            }
            2 * m.clamp(-128.0, 127.0) as i16
        })
        .collect();
    (q, e, saturated)
}

/// The input scale for a layer: the weights' full 8 bits at the largest exponent that keeps
/// `vth` at most `2^THRESHOLD_BITS` (coarser exponents where the threshold is small beside the
/// weights), so the threshold lands in `(2^9, 2^10]` unless the exponents run out.
fn layer_scale(w: &[f32], v_th: f32) -> f32 {
    input_scale(w.iter().fold(0f32, |m, x| m.max(x.abs())), v_th)
}

/// [`map`]'s input scale for a layer whose largest weight magnitude is `max_abs` and whose
/// threshold is `v_th` (a leaky integrator's nominal one): chip input units per float unit.
pub fn input_scale(max_abs: f32, v_th: f32) -> f32 {
    let max = max_abs as f64;
    if max == 0.0 {
        return (1u32 << THRESHOLD_BITS) as f32 / v_th;
    }
    let limit = (1u32 << THRESHOLD_BITS) as f64;
    let mut best = MIN_WEIGHT_EXP;
    for e in MIN_WEIGHT_EXP..=MAX_WEIGHT_EXP {
        let s = 254.0 * 2f64.powi(e as i32) / max;
        if (v_th as f64 * s).round() <= limit {
            best = e;
        }
    }
    (254.0 * 2f64.powi(best as i32) / max) as f32
}

/// Maps a trained network onto Loihi 2 (Lava's bit-accurate LIF and Dense): dense and
/// convolutional layers into IF, LIF or CubaLIF neurons (a leaky-integrator output: LIF neurons
/// whose threshold is the register's top), optionally recurrent, with sum pooling between them;
/// neurons that rest and reset at zero, positive thresholds. `readout` is the model file's.
pub fn map(net: &Network, readout: Readout) -> Result<Mapped> {
    net.validate()?;
    let mut layers: Vec<Loihi2Layer> = Vec::new();
    let mut approximations = Vec::new();
    let mut shape: [usize; 3] = match net.input_shape[..] {
        [c, h, w] => [c, h, w],
        _ => [net.input_shape.iter().product(), 1, 1],
    };
    let mut pool = 1usize;
    let last = net.layers.len() - 1;
    for (k, l) in net.layers.iter().enumerate() {
        match &l.op {
            Op::Pool { kind: PoolKind::Sum, kernel, stride, .. } => {
                if kernel[0] != kernel[1] || kernel != stride {
                    return Err(cannot(
                        Some(k),
                        "sum pooling folds into the next synapses when square with stride = kernel",
                    ));
                }
                if k == last {
                    return Err(cannot(Some(k), "a pooling at the output has no synapses to fold into"));
                }
                pool *= kernel[0];
                continue;
            }
            Op::Pool { kind: PoolKind::Avg, .. } => {
                return Err(cannot(Some(k), "Loihi 2 (lava-dl) pools by summing; average pooling is not mapped"));
            }
            Op::Conv2d { .. } | Op::Dense { .. } => {}
        }
        let Some(p) = l.neurons else {
            return Err(cannot(Some(k), "every convolution or dense layer feeds LIF neurons"));
        };
        if p.v_leak != 0.0 || p.v_reset != 0.0 {
            return Err(cannot(
                Some(k),
                format!(
                    "Lava's LIF rests and resets at zero; this layer's rest at {} and reset to {}",
                    p.v_leak, p.v_reset
                ),
            ));
        }
        if p.kind != NeuronKind::Li && p.v_th <= 0.0 {
            return Err(cannot(Some(k), format!("thresholds are positive here; this layer's is {}", p.v_th)));
        }
        if l.recurrent_bias.is_some() {
            return Err(cannot(Some(k), "a bias on the recurrent connection is not mapped"));
        }
        let is_li = p.kind == NeuronKind::Li;
        if is_li != (k == last && readout == Readout::MaxMembrane) {
            return Err(cannot(
                Some(k),
                "a leaky-integrator layer is read only as the output of a max-membrane readout",
            ));
        }
        let (op, weight, bias) = match &l.op {
            Op::Conv2d { out_channels, kernel, stride, padding, weight, bias, .. } => (
                CoreOp::Conv { out_channels: *out_channels, kernel: *kernel, stride: *stride, padding: *padding },
                weight,
                bias,
            ),
            Op::Dense { n_out, weight, bias, .. } => (CoreOp::Dense { n_out: *n_out }, weight, bias),
            Op::Pool { .. } => unreachable!("pools are folded above"),
        };
        // the float threshold decides the scale; a leaky integrator's nominal one stands in
        let v_th = if p.v_th > 0.0 { p.v_th } else { 1.0 };
        let scale = layer_scale(weight, v_th);
        let (weights, weight_exp, sat) = quantise_block(weight, scale);
        let (recurrent, recurrent_weight_exp, sat_r) = match &l.recurrent {
            Some(r) => {
                let (q, e, s) = quantise_block(r, scale);
                (Some(q), e, s)
            }
            None => (None, 0, 0),
        };
        if sat + sat_r > 0 {
            approximations.push(Approximation::WeightsSaturated { layer: k, count: sat + sat_r });
        }
        let (du, dv) = match p.kind {
            NeuronKind::CubaLif => (du_of(p.alpha), dv_of(p.beta)),
            NeuronKind::Lif | NeuronKind::Li => (4095, dv_of(p.beta)),
            NeuronKind::If => (4095, 0),
        };
        let chip = neurons(p);
        if p.kind == NeuronKind::CubaLif && chip.alpha != p.alpha {
            approximations.push(Approximation::Decay { layer: k, state: "current", float: p.alpha, chip: chip.alpha });
        }
        if p.kind != NeuronKind::If && chip.beta != p.beta {
            approximations.push(Approximation::Decay { layer: k, state: "membrane", float: p.beta, chip: chip.beta });
        }
        if !is_li && p.reset == Reset::Subtract {
            approximations.push(Approximation::ResetToZero { layer: k });
        }
        let vth = if is_li { VTH_MAX } else { (v_th as f64 * scale as f64).round().clamp(1.0, VTH_MAX as f64) as u32 };
        let pooled = [shape[0], shape[1] / pool, shape[2] / pool];
        let neuron_shape = op.neuron_shape(pooled);
        let n: usize = neuron_shape.iter().product();
        let (mut bias_mant, mut bias_exp) = (Vec::new(), Vec::new());
        if let Some(b) = bias {
            let per_channel = n / b.len().max(1);
            let gain = if p.kind == NeuronKind::CubaLif {
                approximations.push(Approximation::BiasIntoMembrane { layer: k });
                1.0 / (1.0 - chip.alpha as f64).max(1.0 / DECAY_UNITY as f64)
            } else {
                1.0
            };
            for j in 0..n {
                let bv = b[j / per_channel] as f64 * gain * scale as f64 * (1u64 << STATE_SHIFT) as f64;
                let mut e = 0u8;
                while e < BIAS_EXP_MAX && (bv / 2f64.powi(e as i32)).abs().round() > BIAS_MANT_MAX as f64 {
                    e += 1;
                }
                let m = (bv / 2f64.powi(e as i32)).round().clamp(-(BIAS_MANT_MAX as f64) - 1.0, BIAS_MANT_MAX as f64);
                bias_mant.push(m as i16);
                bias_exp.push(e);
            }
        }
        layers.push(Loihi2Layer {
            in_shape: shape,
            pool,
            op,
            weights,
            weight_exp,
            recurrent,
            recurrent_weight_exp,
            du,
            dv,
            vth,
            bias_mant,
            bias_exp,
            scale,
        });
        shape = neuron_shape;
        pool = 1;
    }
    approximations.push(Approximation::Latency { layers: layers.len() });
    let spec = Loihi2Spec { layers, readout };
    spec.validate()?;
    Ok(Mapped { spec, approximations })
}

impl Loihi2Spec {
    /// Checks shapes and ranges: what Lava's models take.
    pub fn validate(&self) -> Result<()> {
        if self.layers.is_empty() {
            return Err(cannot(None, "no layers"));
        }
        for (k, l) in self.layers.iter().enumerate() {
            if l.pool == 0 {
                return Err(cannot(Some(k), "a pooling of 0"));
            }
            let [pc, ph, pw] = l.pooled_shape();
            let want = match l.op {
                CoreOp::Conv { out_channels, kernel, stride, .. } => {
                    if stride.contains(&0) || kernel.contains(&0) {
                        return Err(cannot(Some(k), "kernel and stride are at least 1"));
                    }
                    out_channels * pc * kernel[0] * kernel[1]
                }
                CoreOp::Dense { n_out } => n_out * pc * ph * pw,
            };
            if l.weights.len() != want {
                return Err(cannot(Some(k), format!("{} weights, the shapes need {want}", l.weights.len())));
            }
            let n = l.n_neurons();
            let bad = |w: &i16| w % 2 != 0 || !(-256..=254).contains(w);
            if l.weights.iter().any(bad) || l.recurrent.as_ref().is_some_and(|r| r.iter().any(bad)) {
                return Err(cannot(Some(k), "weights are even integers in [-256, 254] (8 bits, mixed sign)"));
            }
            if let Some(r) = &l.recurrent
                && r.len() != n * n
            {
                return Err(cannot(Some(k), format!("{} recurrent weights for {n} neurons", r.len())));
            }
            for e in [l.weight_exp, l.recurrent_weight_exp] {
                if !(MIN_WEIGHT_EXP..=MAX_WEIGHT_EXP).contains(&e) {
                    return Err(cannot(
                        Some(k),
                        format!("weight exponent {e} outside {MIN_WEIGHT_EXP}..={MAX_WEIGHT_EXP}"),
                    ));
                }
            }
            if l.du > 4095 || l.dv > 4095 {
                return Err(cannot(Some(k), format!("du {} and dv {} are 12-bit", l.du, l.dv)));
            }
            if l.vth == 0 || l.vth > VTH_MAX {
                return Err(cannot(Some(k), format!("vth {} outside 1..={VTH_MAX}", l.vth)));
            }
            if !l.bias_mant.is_empty()
                && (l.bias_mant.len() != n
                    || l.bias_exp.len() != n
                    || l.bias_mant.iter().any(|&m| (m as i32) > BIAS_MANT_MAX || (m as i32) < -BIAS_MANT_MAX - 1)
                    || l.bias_exp.iter().any(|&e| e > BIAS_EXP_MAX))
            {
                return Err(cannot(
                    Some(k),
                    format!("a bias per neuron ({n}): 13-bit mantissas, exponents 0..={BIAS_EXP_MAX}"),
                ));
            }
            if k > 0 {
                let prev = self.layers[k - 1].neuron_shape();
                if prev != l.in_shape && prev.iter().product::<usize>() != l.in_shape.iter().product::<usize>() {
                    return Err(cannot(Some(k), format!("takes {:?}, the layer before has {prev:?}", l.in_shape)));
                }
            }
        }
        Ok(())
    }

    pub fn n_in(&self) -> usize {
        self.layers[0].in_shape.iter().product()
    }

    pub fn n_out(&self) -> usize {
        self.layers.last().map_or(0, Loihi2Layer::n_neurons)
    }

    /// Steps from an input to the output's answer: one per synapse block.
    pub fn latency_steps(&self) -> usize {
        self.layers.len()
    }

    pub fn compile(self) -> Result<Loihi2> {
        Loihi2::new(self)
    }
}

/// One layer's synapses, ready to run.
#[derive(Debug, Clone, PartialEq)]
struct Synapses {
    fanout: Block,
    /// Input index to pooled index (`u32::MAX`: beyond the last whole window); empty without
    /// pooling.
    pool_map: Vec<u32>,
    recurrent: Option<Block>,
}

impl Synapses {
    /// Whether the layer's blocks are held as whole rows (its touched neurons then kept as bits).
    fn rows(&self) -> bool {
        matches!(self.fanout, Block::Rows(_))
    }
}

/// A synapse block as it runs: a list of targets per input, or, for a dense block with at least
/// [`ROWS_MIN_DENSITY`] of its synapses non-zero, whole rows of weights (zeros included) that a
/// spike adds with vector instructions. The same sums either way.
#[derive(Debug, Clone, PartialEq)]
enum Block {
    Sparse(Fanout),
    Rows(Rows),
}

/// The share of non-zero synapses from which a dense block runs as whole rows. On the raw1350
/// twin (nearly every synapse non-zero) rows cut the chip's time per sample by about 45% (`cargo
/// bench --bench chip_loihi2`, 2026-12-04), so a row's add costs a fraction of a scattered one's
/// per synapse; a quarter is a cautious guess at the break-even, which was not measured.
const ROWS_MIN_DENSITY: f64 = 0.25;

/// A dense block as rows: `weight[pre][post]` (zeros included), each row's non-zero targets as
/// bits (the neurons it touches, as the target list would mark them), and their count (the
/// synaptic operations of one spike).
#[derive(Debug, Clone, PartialEq)]
struct Rows {
    n_out: usize,
    words: usize,
    weight: Vec<i32>,
    mask: Vec<u64>,
    nnz: Vec<u32>,
}

impl Rows {
    fn of(f: &Fanout, n_out: usize) -> Rows {
        let n_in = f.start.len() - 1;
        let words = n_out.div_ceil(64);
        let mut r =
            Rows { n_out, words, weight: vec![0; n_in * n_out], mask: vec![0; n_in * words], nnz: vec![0; n_in] };
        for pre in 0..n_in {
            let (posts, weights) = f.of(pre);
            for (&post, &w) in posts.iter().zip(weights) {
                let p = post as usize;
                r.weight[pre * n_out + p] = w;
                r.mask[pre * words + p / 64] |= 1 << (p % 64);
            }
            r.nnz[pre] = posts.len() as u32;
        }
        r
    }

    /// Adds `count` spikes of `pre` into `acc` and marks their targets in `touched`; returns the
    /// synaptic operations (the non-zero synapses).
    fn add(&self, pre: usize, count: i64, acc: &mut [i64], touched: &mut [u64]) -> u64 {
        let row = &self.weight[pre * self.n_out..(pre + 1) * self.n_out];
        let acc = &mut acc[..self.n_out];
        // a spike (count 1) without the multiply, which AVX2 has no vector form of for 64 bits:
        // without this branch the chip took 1.2-1.4x the float engine's time, not 1.0-1.1x
        // (`cargo bench --bench chip_loihi2`, 2026-12-04)
        if count == 1 {
            for (a, &w) in acc.iter_mut().zip(row) {
                *a += w as i64;
            }
        } else {
            for (a, &w) in acc.iter_mut().zip(row) {
                *a += count * w as i64;
            }
        }
        for (t, &m) in touched.iter_mut().zip(&self.mask[pre * self.words..(pre + 1) * self.words]) {
            *t |= m;
        }
        self.nnz[pre] as u64
    }
}

/// A [`Loihi2Spec`] ready to run, shared by every stream ([`Loihi2State`] is each stream's own).
#[derive(Debug, Clone, PartialEq)]
pub struct Loihi2 {
    spec: Loihi2Spec,
    synapses: Vec<Synapses>,
    /// Each layer's bias, `bias_mant << bias_exp` (empty: none).
    bias: Vec<Vec<i32>>,
}

/// One layer's state in one stream.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LayerState {
    pub u: Vec<i32>,
    pub v: Vec<i32>,
    /// This step's spikes (ascending in a stepped run).
    pub fired: Vec<u32>,
    /// Accumulators the synapse blocks send at the next step (feed-forward, recurrent).
    next_ff: Vec<i64>,
    next_rec: Vec<i64>,
    /// Neurons with something in the accumulators, and the flags behind the list (a layer whose
    /// blocks run as rows keeps them as bits instead, `touched_bits`).
    touched: Vec<u32>,
    touched_bits: Vec<u64>,
    /// This step's input per neuron (zero between uses), and the neurons that have one.
    a_in: Vec<i64>,
    incoming: Vec<u32>,
    is_touched: Vec<bool>,
    /// Neurons with a non-zero state (event-driven run), and the flags behind the list.
    active: Vec<u32>,
    is_active: Vec<bool>,
}

/// One stream's state on Loihi 2 (the spec is shared).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Loihi2State {
    pub layers: Vec<LayerState>,
    /// Output spikes per output neuron since rest.
    pub out_spike_counts: Vec<u32>,
    /// The highest output membrane since rest, per output neuron.
    pub out_v_max: Vec<i32>,
    pub step: u64,
    pub stats: Loihi2Stats,
}

/// Work done, per stream.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct Loihi2Stats {
    pub input_events: u64,
    /// Synaptic operations: one weight added to one accumulator (a step's input events at one
    /// channel are one graded spike: one operation per synapse).
    pub synops: u64,
    pub spikes: u64,
    pub spikes_per_layer: Vec<u64>,
    pub output_spikes: u64,
    pub neuron_updates: u64,
}

/// Lava's decay: `x * (4096 - d)`, then `sign * (|.| >> 12)`.
#[inline]
fn decay(x: i32, d: i64) -> i64 {
    let y = x as i64 * (DECAY_UNITY - d);
    y.signum() * (y.abs() >> DECAY_BITS)
}

/// Lava's `np.left_shift` / `np.right_shift` by the weight exponent.
#[inline]
fn shift(a: i64, e: i8) -> i64 {
    if e > 0 { a << e } else { a >> (-e) }
}

/// One LIF neuron of `PyLifModelBitAcc` with input `a` (already shifted by the exponent):
/// returns whether it spiked.
#[inline]
fn lif(u: &mut i32, v: &mut i32, a: i64, du: i64, dv: i64, bias: i64, vth6: i64) -> bool {
    // the current: decay, input << 6, Lava's wrap at 24 bits (u stored in 32 bits)
    let c = decay(*u, du + 1) + (a << STATE_SHIFT);
    let wrapped = if c > STATE_MAX {
        c - 2 * STATE_MAX
    } else if c <= -STATE_MAX {
        c + 2 * STATE_MAX
    } else {
        c
    };
    *u = wrapped as i32;
    let nv = (decay(*v, dv) + *u as i64 + bias).clamp(-STATE_MAX + 1, STATE_MAX - 1);
    if nv > vth6 {
        *v = 0;
        true
    } else {
        *v = nv as i32;
        false
    }
}

impl Loihi2 {
    pub fn new(spec: Loihi2Spec) -> Result<Loihi2> {
        Loihi2::with_rows_from(spec, ROWS_MIN_DENSITY)
    }

    /// [`Loihi2::new`] with dense blocks run as rows from `min_density` of non-zero synapses on
    /// (0: every dense block; above 1: none).
    fn with_rows_from(spec: Loihi2Spec, min_density: f64) -> Result<Loihi2> {
        spec.validate()?;
        let mut synapses = Vec::new();
        let mut bias = Vec::new();
        for l in &spec.layers {
            let fanout = Fanout::build(l.pooled_shape(), &l.op, |i| l.weights[i] as i32);
            let n = l.n_neurons();
            let n_in: usize = l.pooled_shape().iter().product();
            let rows =
                matches!(l.op, CoreOp::Dense { .. }) && fanout.post.len() as f64 >= min_density * (n_in * n) as f64;
            let block = |f: Fanout| if rows { Block::Rows(Rows::of(&f, n)) } else { Block::Sparse(f) };
            let pool_map = if l.pool == 1 {
                Vec::new()
            } else {
                let [c, h, w] = l.in_shape;
                let p = l.pool;
                let (oh, ow) = (h / p, w / p);
                (0..c * h * w)
                    .map(|j| {
                        let (ch, y, x) = (j / (h * w), (j / w) % h, j % w);
                        if y / p >= oh || x / p >= ow { u32::MAX } else { ((ch * oh + y / p) * ow + x / p) as u32 }
                    })
                    .collect()
            };
            let recurrent = l
                .recurrent
                .as_ref()
                .map(|r| block(Fanout::build([n, 1, 1], &CoreOp::Dense { n_out: n }, |i| r[i] as i32)));
            synapses.push(Synapses { fanout: block(fanout), pool_map, recurrent });
            bias.push(l.bias_mant.iter().zip(&l.bias_exp).map(|(&m, &e)| (m as i32) << e).collect());
        }
        Ok(Loihi2 { spec, synapses, bias })
    }

    pub fn spec(&self) -> &Loihi2Spec {
        &self.spec
    }

    /// A stream at rest.
    pub fn state(&self) -> Loihi2State {
        let layers = self
            .spec
            .layers
            .iter()
            .zip(&self.synapses)
            .map(|(l, syn)| {
                let n = l.n_neurons();
                LayerState {
                    u: vec![0; n],
                    v: vec![0; n],
                    next_ff: vec![0; n],
                    next_rec: vec![0; n],
                    a_in: vec![0; n],
                    touched_bits: if syn.rows() { vec![0; n.div_ceil(64)] } else { Vec::new() },
                    is_touched: vec![false; n],
                    is_active: vec![false; n],
                    ..LayerState::default()
                }
            })
            .collect();
        let n_out = self.spec.n_out();
        Loihi2State {
            layers,
            out_spike_counts: vec![0; n_out],
            out_v_max: vec![i32::MIN; n_out],
            stats: Loihi2Stats { spikes_per_layer: vec![0; self.spec.layers.len()], ..Loihi2Stats::default() },
            ..Loihi2State::default()
        }
    }

    /// Adds `count` spikes of input `pre` into layer `k`'s accumulators for the next step.
    fn deliver(&self, k: usize, ls: &mut LayerState, pre: usize, count: i64, recurrent: bool) -> u64 {
        let syn = &self.synapses[k];
        let (block, acc, pre) = if recurrent {
            (syn.recurrent.as_ref().expect("a recurrent block"), &mut ls.next_rec, pre)
        } else {
            let pre = if syn.pool_map.is_empty() { pre } else { syn.pool_map[pre] as usize };
            if pre == u32::MAX as usize {
                return 0;
            }
            (&syn.fanout, &mut ls.next_ff, pre)
        };
        let fan = match block {
            Block::Rows(r) => return r.add(pre, count, acc, &mut ls.touched_bits),
            Block::Sparse(f) => f,
        };
        let (posts, weights) = fan.of(pre);
        for (&post, &w) in posts.iter().zip(weights) {
            let p = post as usize;
            acc[p] += count * w as i64;
            if !ls.is_touched[p] {
                ls.is_touched[p] = true;
                ls.touched.push(post);
            }
        }
        // a graded spike is one message: one synaptic operation per synapse, its payload
        // multiplying the weight
        posts.len() as u64
    }

    /// One step: `channels` (ascending, no repeats) and their event counts are this step's input
    /// (graded spikes into the first block). Afterwards each layer's `fired` holds its spikes.
    pub fn step(&self, st: &mut Loihi2State, channels: &[u32], events: &[u16], run: Run) -> Result<()> {
        super::check_step_input(channels, events, self.spec.n_in(), st.step)?;
        let last = self.spec.layers.len() - 1;
        // 1. what every block accumulated last step, shifted by its exponent, taken before
        //    anything is delivered
        for (l, ls) in self.spec.layers.iter().zip(st.layers.iter_mut()) {
            ls.incoming.clear();
            let mut take = |j: usize| {
                ls.a_in[j] = shift(std::mem::take(&mut ls.next_ff[j]), l.weight_exp)
                    + shift(std::mem::take(&mut ls.next_rec[j]), l.recurrent_weight_exp);
            };
            if ls.touched_bits.is_empty() {
                for &j in &ls.touched {
                    ls.is_touched[j as usize] = false;
                    take(j as usize);
                }
                std::mem::swap(&mut ls.incoming, &mut ls.touched);
            } else {
                // ascending rather than in the order first touched: the same neurons, and
                // nothing after depends on their order (a step's spikes are sorted)
                for (w, bits) in ls.touched_bits.iter_mut().enumerate() {
                    let mut b = std::mem::take(bits);
                    while b != 0 {
                        let j = w * 64 + b.trailing_zeros() as usize;
                        b &= b - 1;
                        take(j);
                        ls.incoming.push(j as u32);
                    }
                }
            }
        }
        // 2. this step's input events into the first block
        for (&c, &n) in channels.iter().zip(events) {
            if n > 0 {
                st.stats.input_events += n as u64;
                st.stats.synops += self.deliver(0, &mut st.layers[0], c as usize, n as i64, false);
            }
        }
        // 3. the neurons, layer by layer; their spikes into the blocks for the next step
        for (k, l) in self.spec.layers.iter().enumerate() {
            let (du, dv, vth6) = (l.du as i64, l.dv as i64, (l.vth as i64) << STATE_SHIFT);
            let bias = &self.bias[k];
            let ls = &mut st.layers[k];
            ls.fired.clear();
            let n = ls.u.len();
            if run == Run::Stepped || !bias.is_empty() || k == last {
                for j in 0..n {
                    let b = bias.get(j).copied().unwrap_or(0) as i64;
                    let a = std::mem::take(&mut ls.a_in[j]);
                    if lif(&mut ls.u[j], &mut ls.v[j], a, du, dv, b, vth6) {
                        ls.fired.push(j as u32);
                    }
                }
                st.stats.neuron_updates += n as u64;
            } else {
                // the neurons with a state, and those with input
                for &j in &ls.incoming {
                    if !ls.is_active[j as usize] {
                        ls.is_active[j as usize] = true;
                        ls.active.push(j);
                    }
                }
                let mut keep = 0;
                for i in 0..ls.active.len() {
                    let j = ls.active[i];
                    let ju = j as usize;
                    let a = std::mem::take(&mut ls.a_in[ju]);
                    if lif(&mut ls.u[ju], &mut ls.v[ju], a, du, dv, 0, vth6) {
                        ls.fired.push(j);
                    }
                    if ls.u[ju] != 0 || ls.v[ju] != 0 {
                        ls.active[keep] = j;
                        keep += 1;
                    } else {
                        ls.is_active[ju] = false;
                    }
                }
                st.stats.neuron_updates += ls.active.len() as u64;
                ls.active.truncate(keep);
                ls.fired.sort_unstable();
            }
            let fired = std::mem::take(&mut ls.fired);
            st.stats.spikes += fired.len() as u64;
            st.stats.spikes_per_layer[k] += fired.len() as u64;
            if k == last {
                st.stats.output_spikes += fired.len() as u64;
                for &j in &fired {
                    st.out_spike_counts[j as usize] += 1;
                }
                for (m, &v) in st.out_v_max.iter_mut().zip(&st.layers[k].v) {
                    *m = (*m).max(v);
                }
            } else {
                for &j in &fired {
                    st.stats.synops += self.deliver(k + 1, &mut st.layers[k + 1], j as usize, 1, false);
                }
            }
            if l.recurrent.is_some() {
                for &j in &fired {
                    st.stats.synops += self.deliver(k, &mut st.layers[k], j as usize, 1, true);
                }
            }
            st.layers[k].fired = fired;
        }
        st.step += 1;
        Ok(())
    }

    /// The steps a sample runs without input after its last one, for the output to answer it.
    pub fn drain_steps(&self) -> usize {
        self.spec.latency_steps()
    }

    /// A stream's readout since rest: the highest output membrane (max-membrane readout) or the
    /// output spikes counted.
    pub fn readout(&self, st: &Loihi2State) -> Vec<f32> {
        match self.spec.readout {
            Readout::MaxMembrane => st.out_v_max.iter().map(|&v| v as f32).collect(),
            Readout::SpikeCount => st.out_spike_counts.iter().map(|&c| c as f32).collect(),
        }
    }

    /// A whole sample from rest, then [`Loihi2::drain_steps`] steps without input. Returns the
    /// readout and the stream's work.
    pub fn run_sample<'a>(
        &self,
        steps: impl IntoIterator<Item = (&'a [u32], &'a [u16])>,
        run: Run,
    ) -> Result<(Vec<f32>, Loihi2Stats)> {
        let mut st = self.state();
        for (channels, events) in steps {
            self.step(&mut st, channels, events, run)?;
        }
        for _ in 0..self.drain_steps() {
            self.step(&mut st, &[], &[], run)?;
        }
        Ok((self.readout(&st), st.stats))
    }
}

/// A layer's synapses per pre-synaptic input: targets and integer weights (a convolution's
/// shared weights written out per input).
#[derive(Debug, Clone, PartialEq)]
struct Fanout {
    start: Vec<u32>,
    post: Vec<u32>,
    weight: Vec<i32>,
}

impl Fanout {
    fn of(&self, pre: usize) -> (&[u32], &[i32]) {
        let r = self.start[pre] as usize..self.start[pre + 1] as usize;
        (&self.post[r.clone()], &self.weight[r])
    }

    /// The synapses of `op` over an input of `in_shape`, `weight(i)` the `i`-th weight in the
    /// op's layout (PyTorch's); zero weights are left out.
    fn build(in_shape: [usize; 3], op: &CoreOp, weight: impl Fn(usize) -> i32) -> Fanout {
        let [ic, ih, iw] = in_shape;
        let n_in = ic * ih * iw;
        let mut per_pre: Vec<Vec<(u32, i32)>> = vec![Vec::new(); n_in];
        match *op {
            CoreOp::Dense { n_out } => {
                for o in 0..n_out {
                    for (i, pre) in per_pre.iter_mut().enumerate() {
                        let w = weight(o * n_in + i);
                        if w != 0 {
                            pre.push((o as u32, w));
                        }
                    }
                }
            }
            CoreOp::Conv { out_channels, kernel: [kh, kw], stride: [sy, sx], padding: [py, px] } => {
                let [_, oh, ow] = op.neuron_shape(in_shape);
                for oc in 0..out_channels {
                    for oy in 0..oh {
                        for ox in 0..ow {
                            let post = ((oc * oh + oy) * ow + ox) as u32;
                            for c in 0..ic {
                                for ky in 0..kh {
                                    let Some(y) = (oy * sy + ky).checked_sub(py).filter(|&y| y < ih) else {
                                        continue;
                                    };
                                    for kx in 0..kw {
                                        let Some(x) = (ox * sx + kx).checked_sub(px).filter(|&x| x < iw) else {
                                            continue;
                                        };
                                        let w = weight(((oc * ic + c) * kh + ky) * kw + kx);
                                        if w != 0 {
                                            per_pre[(c * ih + y) * iw + x].push((post, w));
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        let mut f = Fanout { start: vec![0], post: Vec::new(), weight: Vec::new() };
        for pre in per_pre {
            for (p, w) in pre {
                f.post.push(p);
                f.weight.push(w);
            }
            f.start.push(f.post.len() as u32);
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::Layer;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn dense(n_in: usize, weights: Vec<i16>, exp: i8, du: u16, dv: u16, vth: u32) -> Loihi2Layer {
        Loihi2Layer {
            in_shape: [n_in, 1, 1],
            pool: 1,
            op: CoreOp::Dense { n_out: weights.len() / n_in },
            weights,
            weight_exp: exp,
            recurrent: None,
            recurrent_weight_exp: 0,
            du,
            dv,
            vth,
            bias_mant: Vec::new(),
            bias_exp: Vec::new(),
            scale: 1.0,
        }
    }

    /// Lava 0.10.0's own run (`Loihi2SimCfg(select_tag="fixed_pt")`: `PyDenseModelBitAcc`,
    /// `PyLifModelBitAcc`): RingBuffer(3 graded inputs) -> Dense(exp 1) -> LIF(du 409, dv 819,
    /// vth 700) -> Dense(exp -1) -> LIF(du 4095, dv 200, vth 40, bias 5 << 2 and -3), every
    /// step's states and spikes as Lava's monitors gave them.
    #[test]
    fn equals_lava_bit_accurate_run() {
        let mut out = dense(2, vec![120, -40, -60, 90], -1, 4095, 200, 40);
        out.bias_mant = vec![5, -3];
        out.bias_exp = vec![2, 0];
        let spec = Loihi2Spec {
            layers: vec![dense(3, vec![100, -50, 30, 20, 60, -80], 1, 409, 819, 700), out],
            readout: Readout::SpikeCount,
        };
        let chip = spec.compile().unwrap();
        let mut x = vec![vec![0u16; 3]; 14];
        for (t, c, n) in [
            (0, 0, 3),
            (0, 2, 1),
            (1, 1, 2),
            (2, 0, 1),
            (3, 0, 4),
            (3, 1, 1),
            (5, 2, 5),
            (6, 0, 2),
            (8, 1, 3),
            (9, 0, 1),
        ] {
            x[t][c] = n;
        }
        let v1 = [
            [0, 42240, 0, 35487, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
            [0, -2560, 11009, 23117, 0, 27714, -4089, -21783, -34085, -19219, -5572, 4365, 11430, 16287],
        ];
        let u1 = [
            [0, 42240, 25211, 35487, 76734, 69053, 81340, 98798, 88908, 60808, 67521, 60762, 54679, 49205],
            [0, -2560, 13057, 14310, 30797, 27714, -26261, -18512, -16658, 8050, 9804, 8822, 7938, 7143],
        ];
        let s1 = [[0, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1], [0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0]];
        let v2 = [
            [20, 39, 57, 0, 20, 0, 0, 0, 0, 0, 0, 0, 0, 0],
            [-3, -5, -7, -1929, -1837, -790, -2674, -4466, -6170, -7791, -9333, -10800, -12195, -13522],
        ];
        let s2 = [[0, 0, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1], [0u32; 14]];
        for run in [Run::Stepped, Run::EventDriven] {
            let mut st = chip.state();
            for (t, row) in x.iter().enumerate() {
                let channels: Vec<u32> = (0..3u32).filter(|&c| row[c as usize] > 0).collect();
                let events: Vec<u16> = channels.iter().map(|&c| row[c as usize]).collect();
                chip.step(&mut st, &channels, &events, run).unwrap();
                for j in 0..2 {
                    assert_eq!(st.layers[0].v[j], v1[j][t], "v1[{j}] at {t}");
                    assert_eq!(st.layers[0].u[j], u1[j][t], "u1[{j}] at {t}");
                    assert_eq!(st.layers[0].fired.contains(&(j as u32)) as u32, s1[j][t], "s1[{j}] at {t}");
                    assert_eq!(st.layers[1].v[j], v2[j][t], "v2[{j}] at {t}");
                    assert_eq!(st.layers[1].fired.contains(&(j as u32)) as u32, s2[j][t], "s2[{j}] at {t}");
                }
            }
        }
    }

    #[test]
    fn decay_rounds_towards_zero_and_the_current_wraps_as_lava() {
        // 1000 * 3277 / 4096 = 800.05: 800 either side of zero (a floor would give -801)
        assert_eq!(decay(1000, 819), 800);
        assert_eq!(decay(-1000, 819), -800);
        let (mut u, mut v) = (0, 0);
        // a current past 2^23 wraps to the negative side
        lif(&mut u, &mut v, (1 << 17) + 5, 4095, 0, 0, i64::MAX);
        assert_eq!(u as i64, ((1i64 << 17) + 5) * 64 - 2 * STATE_MAX);
        // the membrane clips at +-(2^23 - 1)
        let (mut u, mut v) = (0, 0);
        lif(&mut u, &mut v, (1 << 16) + 100, 4095, 0, 0, i64::MAX);
        lif(&mut u, &mut v, 0, 0, 0, 0, i64::MAX);
        assert_eq!(v as i64, STATE_MAX - 1);
        assert_eq!(du_of(0.9), 409);
        assert_eq!(dv_of(0.8), 819);
        assert_eq!(du_of(0.0), 4095);
        assert_eq!(dv_of(1.0), 0);
    }

    fn lif_layer(op: Op, p: NeuronParams) -> Layer {
        Layer { op, neurons: Some(p), recurrent: None, recurrent_bias: None }
    }

    /// 2x8x8 -> conv 3x3 (4) -> CubaLIF -> sum-pool 2 -> conv 3x3 (3, stride 2) -> LIF (biased,
    /// recurrent, reset by subtraction) -> dense 5 LI.
    fn random_net(seed: u64) -> Network {
        let p = [
            NeuronParams::cuba_lif(0.8, 0.95),
            NeuronParams::lif(0.9).with_reset(Reset::Subtract),
            NeuronParams::leaky_integrator(0.9),
        ];
        let mut net = super::super::test_nets::conv_pool_dense(seed, p, true);
        let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
        net.layers[2].recurrent = Some((0..12 * 12).map(|_| rng.random_range(-0.5..0.5)).collect());
        net
    }

    #[test]
    fn event_driven_is_stepped_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for seed in [1, 2, 3] {
            let m = map(&random_net(seed), Readout::MaxMembrane).unwrap();
            let chip = m.spec.compile().unwrap();
            let mut a = chip.state();
            let mut b = chip.state();
            for _ in 0..40 {
                let ch: Vec<u32> = (0..128u32).filter(|_| rng.random_bool(0.15)).collect();
                let ev: Vec<u16> = ch.iter().map(|_| rng.random_range(1..4u16)).collect();
                chip.step(&mut a, &ch, &ev, Run::Stepped).unwrap();
                chip.step(&mut b, &ch, &ev, Run::EventDriven).unwrap();
                for (x, y) in a.layers.iter().zip(&b.layers) {
                    assert_eq!((&x.u, &x.v, &x.fired), (&y.u, &y.v, &y.fired));
                }
            }
            assert!(a.stats.spikes_per_layer[0] > 0 && a.stats.spikes_per_layer[1] > 0, "the test network spikes");
            assert_eq!(chip.readout(&a), chip.readout(&b));
            assert_eq!((a.stats.synops, a.stats.spikes), (b.stats.synops, b.stats.spikes));
            assert!(b.stats.neuron_updates < a.stats.neuron_updates);
        }
    }

    #[test]
    fn dense_blocks_as_rows_run_as_their_target_lists() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        // 128 inputs -> 16 recurrent LIF with a bias -> 5 LIF, a third of the weights zero
        let mut w = |n: usize| -> Vec<i16> {
            (0..n).map(|_| if rng.random_bool(0.33) { 0 } else { 2 * rng.random_range(-60..60i16) }).collect()
        };
        let mut hidden = dense(128, w(128 * 16), 0, 410, 205, 300);
        hidden.recurrent = Some(w(16 * 16));
        hidden.recurrent_weight_exp = -1;
        hidden.bias_mant = w(16).iter().map(|b| b / 8).collect();
        hidden.bias_exp = vec![1; 16];
        let recurrent_dense =
            Loihi2Spec { layers: vec![hidden, dense(16, w(16 * 5), 1, 820, 410, 200)], readout: Readout::MaxMembrane };
        let specs = [1, 2, 3].map(|seed| map(&random_net(seed), Readout::MaxMembrane).unwrap().spec);
        for spec in specs.into_iter().chain([recurrent_dense]) {
            let rows = Loihi2::with_rows_from(spec.clone(), 0.0).unwrap();
            let lists = Loihi2::with_rows_from(spec, 2.0).unwrap();
            assert!(rows.synapses.iter().any(|s| s.rows()), "a block as rows");
            assert!(lists.synapses.iter().all(|s| !s.rows()));
            for run in [Run::Stepped, Run::EventDriven] {
                let (mut a, mut b) = (rows.state(), lists.state());
                for _ in 0..40 {
                    let ch: Vec<u32> = (0..128u32).filter(|_| rng.random_bool(0.15)).collect();
                    let ev: Vec<u16> = ch.iter().map(|_| rng.random_range(1..4u16)).collect();
                    rows.step(&mut a, &ch, &ev, run).unwrap();
                    lists.step(&mut b, &ch, &ev, run).unwrap();
                    for (x, y) in a.layers.iter().zip(&b.layers) {
                        assert_eq!((&x.u, &x.v, &x.fired), (&y.u, &y.v, &y.fired));
                    }
                }
                let hidden = &a.stats.spikes_per_layer[..a.stats.spikes_per_layer.len() - 1];
                assert!(hidden.iter().all(|&n| n > 0), "every hidden layer spikes: {hidden:?}");
                // the work counted alike too: synapses, spikes, neuron updates
                assert_eq!(a.stats, b.stats);
                assert_eq!((a.out_v_max, a.out_spike_counts), (b.out_v_max, b.out_spike_counts));
            }
        }
    }

    #[test]
    fn map_puts_thresholds_under_2_10_with_full_weights_and_names_what_changed() {
        let net = random_net(4);
        let m = map(&net, Readout::MaxMembrane).unwrap();
        let l0 = &m.spec.layers[0];
        assert!(l0.vth > 1 << (THRESHOLD_BITS - 1) && l0.vth <= 1 << THRESHOLD_BITS, "vth {}", l0.vth);
        assert_eq!(l0.weights.iter().map(|w| w.abs()).max(), Some(254));
        assert_eq!((l0.du, l0.dv), (du_of(0.8), dv_of(0.95)));
        // the pool folds into the second layer; its bias and recurrence map
        let l1 = &m.spec.layers[1];
        assert_eq!((l1.pool, l1.in_shape), (2, [4, 8, 8]));
        assert_eq!(l1.bias_mant.len(), 12);
        assert!(l1.recurrent.is_some());
        assert_eq!(m.spec.layers[2].vth, VTH_MAX);
        let text: Vec<String> = m.approximations.iter().map(ToString::to_string).collect();
        assert!(text.iter().any(|t| t.contains("layer 2: reset by subtraction")), "{text:?}");
        assert!(text.iter().any(|t| t.contains("3 synapse blocks")), "{text:?}");
        // average pooling and a leaky integrator read by spike counts are refused, with the layer
        let mut avg = net.clone();
        avg.layers[1].op = Op::Pool { kind: PoolKind::Avg, in_shape: [4, 8, 8], kernel: [2, 2], stride: [2, 2] };
        assert!(map(&avg, Readout::MaxMembrane).unwrap_err().to_string().contains("layer 1: "));
        assert!(map(&net, Readout::SpikeCount).unwrap_err().to_string().contains("layer 3: "));
    }

    #[test]
    fn a_network_on_the_chips_grid_is_the_float_network_delayed_a_step_per_layer() {
        // IF neurons (no decay to round), weights on a grid of 1/127 (what 8 bits hold at the
        // mapper's scale): the float rule, computed exactly (membranes in units of 1/127), and
        // the chip spike alike, the chip one step later per layer
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let m0: Vec<i32> = (0..6 * 10).map(|_| rng.random_range(-127..=127)).collect();
        let mut m1: Vec<i32> = (0..4 * 6).map(|_| rng.random_range(-127..=127)).collect();
        let mut m0 = m0;
        // the largest magnitude at the top of the grid: the mapper's scale is then exactly 127
        (m0[0], m1[0]) = (127, 127);
        let f = |m: &[i32]| m.iter().map(|&x| x as f32 / 127.0).collect::<Vec<f32>>();
        let p = NeuronParams::integrate_and_fire();
        let net = Network::new(
            vec![10],
            vec![
                lif_layer(Op::Dense { n_in: 10, n_out: 6, weight: f(&m0), bias: None }, p),
                lif_layer(Op::Dense { n_in: 6, n_out: 4, weight: f(&m1), bias: None }, p),
            ],
        )
        .unwrap();
        let chip = map(&net, Readout::SpikeCount).unwrap().spec.compile().unwrap();
        assert_eq!(chip.drain_steps(), 2);
        let steps = 100;
        let inputs: Vec<Vec<u32>> = (0..steps).map(|_| (0..10u32).filter(|_| rng.random_bool(0.6)).collect()).collect();
        // the float rule: v += W x; a spike if v > 1 (127 units), then v = 0
        let (mut v0, mut v1) = (vec![0i32; 6], vec![0i32; 4]);
        let mut want: Vec<Vec<u32>> = Vec::new();
        for x in &inputs {
            let mut z0 = Vec::new();
            for (o, v) in v0.iter_mut().enumerate() {
                *v += x.iter().map(|&i| m0[o * 10 + i as usize]).sum::<i32>();
                if *v > 127 {
                    *v = 0;
                    z0.push(o);
                }
            }
            let mut z1 = Vec::new();
            for (o, v) in v1.iter_mut().enumerate() {
                *v += z0.iter().map(|&i| m1[o * 6 + i]).sum::<i32>();
                if *v > 127 {
                    *v = 0;
                    z1.push(o as u32);
                }
            }
            want.push(z1);
        }
        let mut st = chip.state();
        let mut got: Vec<Vec<u32>> = Vec::new();
        for k in 0..steps + chip.drain_steps() {
            let ch = inputs.get(k).cloned().unwrap_or_default();
            let ev = vec![1u16; ch.len()];
            chip.step(&mut st, &ch, &ev, Run::Stepped).unwrap();
            if k >= 2 {
                got.push(st.layers[1].fired.clone());
            }
        }
        assert!(want.iter().map(Vec::len).sum::<usize>() > 5, "the test network spikes");
        assert_eq!(got, want);
    }
}
