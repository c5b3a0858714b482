//! Speck (DYNAP-CNN) as Sinabs models it (PyPI `sinabs` 3.1.3, `sinabs/backend/dynapcnn/`): the
//! arithmetic Sinabs's `DynapcnnNetwork` runs on a CPU and writes to the chip. Each core is a
//! convolution (a dense layer is a convolution over its whole input, Sinabs's
//! `_convert_linear_to_conv`), integrate-and-fire neurons and an optional sum pooling of their
//! spikes. Per step, core after core (a core's spikes reach the next core in the same step, as in
//! Sinabs's forward pass):
//!
//! 1. every input event (or pooled spike) adds its 8-bit weight to the membranes its kernel
//!    covers, once per event;
//! 2. every neuron: `n = v / threshold` (truncated) spikes if `v > 0` (Sinabs's `MultiSpike`,
//!    which SynSense recommends for the chip: the chip is asynchronous, so a neuron fires on every
//!    event that carries it past its threshold, several times in one step of the model), then
//!    `v -= n * threshold` or, with `return_to_zero`, `v = 0` after a spike (`MembraneSubtract`,
//!    `MembraneReset`); then `v = max(v, threshold_low)` (`min_v_mem`);
//! 3. the spikes, summed over each `pool x pool` window (`SumPool2d`), are the next core's input.
//!
//! Weights are 8-bit signed, the membrane and both thresholds 16-bit signed
//! (`discretize.py`: `DYNAPCNN_WEIGHT_PRECISION_BITS = 8`, `DYNAPCNN_STATE_PRECISION_BITS = 16`);
//! a step's input is summed whole before the spikes are taken, as Sinabs's time-stepped model sums
//! it (the chip itself fires between events, so its membrane never holds more than a threshold
//! and one weight: the state left after a step fits 16 bits). There is no leak (Speck's leak is a
//! bias applied at a clock of its own; biases are refused).
//!
//! The event-driven run ([`Run::EventDriven`]) updates only neurons that received input in the
//! step (a convolution's position whole, all its channels); a neuron without input keeps a
//! membrane below its threshold (what a step leaves) and stays silent, so it is the stepped run
//! bit for bit (tested).
//!
//! The run keeps a convolution's membranes channel-last (a position's channels side by side) and
//! its weights `[in][ky][kx][out]`, so that an event adds one contiguous run of weights to one
//! contiguous run of membranes per position it reaches, as the float engine does; every index the
//! state shows (spikes, fired neurons, [`Speck::v_mem`]) is in PyTorch's order.
//!
//! [`map`] quantises a trained network as Sinabs's `discretize_conv_spike_` does, one scale per
//! core for its weights and thresholds.

use super::xylo::Run;
use super::{Chip, ChipReset, DecayArithmetic, NumberFormat};
use crate::error::{Error, Result};
use crate::network::{Network, Op, PoolKind};
use crate::neuron::{NeuronKind, Reset};
use serde::{Deserialize, Serialize};

/// Speck's number formats, as Sinabs discretises and configures a network.
pub const FORMAT: NumberFormat = NumberFormat {
    weight_bits: 8,
    max_weight_shift: 0,
    state_bits: 16,
    threshold_bits: 16,
    decay: DecayArithmetic::None,
    reset: ChipReset::SubtractOrZero,
    max_spikes_per_step: None,
    max_output_spikes_per_step: None,
    max_input_events_per_step: None,
    source: "Sinabs 3.1.3 (PyPI sinabs): backend/dynapcnn/discretize.py (DYNAPCNN_WEIGHT_PRECISION_BITS 8, DYNAPCNN_STATE_PRECISION_BITS 16, determine_discretization_scale), chips/dynapcnn.py (threshold_high, threshold_low = min_v_mem or -2^15, return_to_zero, sum pooling), layers/iaf.py with activation.MultiSpike (docs/speck/dangers.md: the spike function that best matches the chip)",
};

/// The membrane's floor: the 16-bit state's minimum, what Sinabs writes to the chip's
/// `threshold_low` when a layer sets no `min_v_mem`.
pub const THRESHOLD_LOW: i16 = i16::MIN;

/// A core's synapses.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum CoreOp {
    /// A 2-D convolution (PyTorch's layout: `weights[out][in][ky][kx]`).
    Conv { out_channels: usize, kernel: [usize; 2], stride: [usize; 2], padding: [usize; 2] },
    /// A dense layer over the flattened input (`weights[out][in]`): on the chip, a convolution
    /// whose kernel covers the whole input.
    Dense { n_out: usize },
}

/// One core: synapses, integrate-and-fire neurons, optional sum pooling of their spikes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpeckCore {
    /// `[channels, height, width]` (a dense core's input may be `[n, 1, 1]`).
    pub in_shape: [usize; 3],
    pub op: CoreOp,
    pub weights: Vec<i8>,
    pub threshold: i16,
    pub threshold_low: i16,
    pub return_to_zero: bool,
    /// Sum pooling of the spikes, `pool x pool`, stride `pool` (1: none).
    pub pool: usize,
    /// Chip units per unit of the float network's state (the quantiser's scale).
    pub scale: f32,
}

impl CoreOp {
    /// The shape `[channels, height, width]` of the neurons the op feeds, over an input of
    /// `in_shape`.
    pub fn neuron_shape(&self, in_shape: [usize; 3]) -> [usize; 3] {
        let [_, h, w] = in_shape;
        match *self {
            CoreOp::Conv { out_channels, kernel, stride, padding } => {
                let o = |n: usize, d: usize| (n + 2 * padding[d]).saturating_sub(kernel[d]) / stride[d] + 1;
                [out_channels, o(h, 0), o(w, 1)]
            }
            CoreOp::Dense { n_out } => [n_out, 1, 1],
        }
    }
}

impl SpeckCore {
    /// The neurons' shape `[channels, height, width]`.
    pub fn neuron_shape(&self) -> [usize; 3] {
        self.op.neuron_shape(self.in_shape)
    }

    /// The shape of what the core sends on (after pooling).
    pub fn out_shape(&self) -> [usize; 3] {
        let [c, h, w] = self.neuron_shape();
        [c, h / self.pool, w / self.pool]
    }
}

/// A network in Speck's formats: its cores in order, the first taking the input events.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpeckSpec {
    pub cores: Vec<SpeckCore>,
}

/// Something of the float network Speck computes otherwise, and what the mapping made of it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Approximation {
    /// The float network's neurons send at most one spike per step; Speck's send as many as
    /// their membrane holds thresholds (Sinabs's `MultiSpike`).
    SeveralSpikesPerStep { layer: usize },
    /// The float membrane has no floor; Speck's stops at `threshold_low`.
    MembraneFloor { layer: usize, floor: i16 },
}

impl std::fmt::Display for Approximation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Approximation::SeveralSpikesPerStep { layer } => write!(
                f,
                "layer {layer}: a neuron sends floor(v / threshold) spikes per step (the asynchronous chip, Sinabs's MultiSpike), where the float network sends one"
            ),
            Approximation::MembraneFloor { layer, floor } => {
                write!(f, "layer {layer}: the membrane stops at {floor} (the 16-bit state's floor)")
            }
        }
    }
}

/// A mapped network and what the mapping changed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Mapped {
    pub spec: SpeckSpec,
    pub approximations: Vec<Approximation>,
}

fn cannot(layer: Option<usize>, what: impl Into<String>) -> Error {
    Error::Chip { chip: Chip::Speck, layer, what: what.into() }
}

/// Sinabs's `determine_discretization_scale`: the factor that takes the values' range to
/// `bits`-bit signed integers (the larger magnitude of the two ends decides, the negative end
/// holding one more value).
pub fn discretization_scale(values: impl IntoIterator<Item = f32>, bits: u8) -> f32 {
    let (min_disc, max_disc) = (-(2f64.powi(bits as i32 - 1)), 2f64.powi(bits as i32 - 1) - 1.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v as f64);
        hi = hi.max(v as f64);
    }
    if !lo.is_finite() || (lo == 0.0 && hi == 0.0) {
        return 1.0;
    }
    let ratio = (min_disc / max_disc).abs();
    let s = if lo.abs() <= hi.abs() * ratio { (max_disc / hi).abs() } else { (min_disc / lo).abs() };
    s as f32
}

/// Maps a trained network onto Speck: what `braille export --target speck` admits (IF neurons, no
/// bias, no recurrence, convolutions and dense layers each feeding IF neurons, sum pooling after
/// them, the cores' memory) with neurons that rest and reset at zero. Each core's weights and
/// threshold take one scale, Sinabs's rule: the largest that keeps the weights in 8 bits and the
/// thresholds (`threshold_low`, `threshold`) in 16, with `threshold_low` the state's floor
/// ([`THRESHOLD_LOW`]; in Sinabs's float units `min_v_mem = -2^15 / scale`).
pub fn map(net: &Network) -> Result<Mapped> {
    net.validate()?;
    crate::nir::check_target(net, crate::nir::Target::Speck).map_err(|e| {
        // "<target>: layer k (node ...): Speck: the rule" as "layer k (node ...): the rule"
        let msg = e.to_string();
        cannot(None, msg.trim_start_matches("<target>: ").replacen(": Speck: ", ": ", 1))
    })?;
    let mut cores: Vec<SpeckCore> = Vec::new();
    let mut approximations = Vec::new();
    let mut shape = net.input_shape.clone();
    for (k, l) in net.layers.iter().enumerate() {
        let in_shape = match shape[..] {
            [c, h, w] => [c, h, w],
            _ => [shape.iter().product(), 1, 1],
        };
        match &l.op {
            Op::Pool { kind: PoolKind::Sum, kernel, .. } => {
                let Some(core) = cores.last_mut() else {
                    return Err(cannot(Some(k), "pooling sits at a core's output: it must follow a spiking layer"));
                };
                core.pool *= kernel[0];
                if ![1, 2, 4].contains(&core.pool) {
                    return Err(cannot(
                        Some(k),
                        format!("a core pools by 1, 2 or 4; the pools before here make {}", core.pool),
                    ));
                }
            }
            Op::Pool { kind: PoolKind::Avg, .. } => {
                return Err(cannot(Some(k), "Speck pools by summing (SumPool2d), not averaging"));
            }
            Op::Conv2d { weight, .. } | Op::Dense { weight, .. } => {
                let Some(p) = l.neurons else {
                    return Err(cannot(Some(k), "every convolution or dense layer feeds IF neurons on its core"));
                };
                if p.kind != NeuronKind::If {
                    return Err(cannot(Some(k), "Speck runs IF neurons only (no leak)"));
                }
                if p.v_leak != 0.0 || p.v_reset != 0.0 {
                    return Err(cannot(
                        Some(k),
                        format!(
                            "Speck's membranes rest and reset at zero; this layer's rest at {} and reset to {}",
                            p.v_leak, p.v_reset
                        ),
                    ));
                }
                if p.v_th <= 0.0 {
                    return Err(cannot(Some(k), format!("thresholds are positive here; this layer's is {}", p.v_th)));
                }
                let scale_w = discretization_scale(weight.iter().copied(), FORMAT.weight_bits);
                let low_float = THRESHOLD_LOW as f32 / scale_w;
                let scale_t = discretization_scale([low_float, p.v_th], FORMAT.state_bits);
                let scale = scale_w.min(scale_t);
                let threshold = (p.v_th * scale).round();
                if threshold < 1.0 {
                    return Err(cannot(Some(k), format!("the threshold {} rounds to zero at scale {scale}", p.v_th)));
                }
                let op = match &l.op {
                    Op::Conv2d { out_channels, kernel, stride, padding, .. } => CoreOp::Conv {
                        out_channels: *out_channels,
                        kernel: *kernel,
                        stride: *stride,
                        padding: *padding,
                    },
                    _ => CoreOp::Dense { n_out: l.op.n_out() },
                };
                approximations.push(Approximation::SeveralSpikesPerStep { layer: k });
                approximations.push(Approximation::MembraneFloor { layer: k, floor: THRESHOLD_LOW });
                cores.push(SpeckCore {
                    in_shape,
                    op,
                    weights: weight.iter().map(|w| (w * scale).round().clamp(-128.0, 127.0) as i8).collect(),
                    threshold: threshold.min(i16::MAX as f32) as i16,
                    threshold_low: THRESHOLD_LOW,
                    return_to_zero: p.reset == Reset::Zero,
                    pool: 1,
                    scale,
                });
            }
        }
        shape = l.op.out_shape();
    }
    let spec = SpeckSpec { cores };
    spec.validate()?;
    Ok(Mapped { spec, approximations })
}

impl SpeckSpec {
    /// Checks shapes and ranges: what the chip's configuration takes.
    pub fn validate(&self) -> Result<()> {
        if self.cores.is_empty() {
            return Err(cannot(None, "no cores"));
        }
        if self.cores.len() > 9 {
            return Err(cannot(None, format!("Speck has 9 cores, the network needs {}", self.cores.len())));
        }
        for (k, c) in self.cores.iter().enumerate() {
            let n_in: usize = c.in_shape.iter().product();
            let want = match c.op {
                CoreOp::Conv { out_channels, kernel, stride, .. } => {
                    if stride.contains(&0) || kernel.contains(&0) {
                        return Err(cannot(Some(k), "kernel and stride are at least 1"));
                    }
                    out_channels * c.in_shape[0] * kernel[0] * kernel[1]
                }
                CoreOp::Dense { n_out } => n_out * n_in,
            };
            if c.weights.len() != want {
                return Err(cannot(Some(k), format!("{} weights, the shapes need {want}", c.weights.len())));
            }
            if c.threshold <= 0 || c.threshold_low > 0 {
                return Err(cannot(
                    Some(k),
                    format!(
                        "thresholds {} (high) and {} (low): the high one positive, the low one at most zero",
                        c.threshold, c.threshold_low
                    ),
                ));
            }
            if ![1, 2, 4].contains(&c.pool) {
                return Err(cannot(Some(k), format!("a core pools by 1, 2 or 4, not {}", c.pool)));
            }
            if k > 0 {
                let prev: usize = self.cores[k - 1].out_shape().iter().product();
                if prev != n_in {
                    return Err(cannot(Some(k), format!("takes {n_in} inputs, the core before sends {prev}")));
                }
            }
        }
        Ok(())
    }

    pub fn n_in(&self) -> usize {
        self.cores[0].in_shape.iter().product()
    }

    pub fn n_out(&self) -> usize {
        self.cores.last().map_or(0, |c| c.out_shape().iter().product())
    }

    /// Ready to run.
    pub fn compile(self) -> Result<Speck> {
        Speck::new(self)
    }
}

/// A core's synapses as a run walks them. A convolution's membranes are kept channel-last
/// (`[y][x][channel]`, a position's channels side by side), so that an input reaches each
/// position its kernel covers as one contiguous run of weights added to one contiguous run of
/// membranes (vector adds); a dense core's membranes are its outputs, reached as one run. The
/// spikes, the pooling and every index the state shows stay in PyTorch's order.
#[derive(Debug, Clone, PartialEq)]
struct CoreRun {
    /// Neurons reached together: a position's channels, or a dense core's outputs.
    group: usize,
    /// Per input (PyTorch's order): its pixel (the list of positions it reaches), the offset of
    /// its channel's weights and its synaptic operations per event (non-zero weights).
    inputs: Vec<InputFan>,
    /// The reached groups of pixel `p`: `targets[offsets[p]..offsets[p + 1]]`, each the first
    /// neuron of the group and the offset of its weights from the channel's.
    offsets: Vec<u32>,
    targets: Vec<(u32, u32)>,
    /// Weights `[in channel][ky][kx][out channel]` (a convolution), `[in][out]` (dense).
    wt: Vec<i32>,
    /// Per neuron (the run's order): its index in PyTorch's order `[channel][y][x]`.
    canonical: Vec<u32>,
    /// Per neuron (the run's order): the index of the pooled output it adds to (PyTorch's order of
    /// the next core's input), or `u32::MAX` beyond the last whole window.
    pool_to: Vec<u32>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct InputFan {
    pixel: u32,
    weights: u32,
    synops: u32,
}

impl CoreRun {
    fn new(core: &SpeckCore) -> CoreRun {
        let [ic, ih, iw] = core.in_shape;
        let n_in = ic * ih * iw;
        let [c, h, w] = core.neuron_shape();
        let mut run = match core.op {
            CoreOp::Dense { n_out } => {
                let mut wt = vec![0; n_in * n_out];
                for o in 0..n_out {
                    for i in 0..n_in {
                        wt[i * n_out + o] = core.weights[o * n_in + i] as i32;
                    }
                }
                let inputs = (0..n_in)
                    .map(|i| InputFan {
                        pixel: 0,
                        weights: (i * n_out) as u32,
                        synops: wt[i * n_out..(i + 1) * n_out].iter().filter(|&&w| w != 0).count() as u32,
                    })
                    .collect();
                CoreRun {
                    group: n_out,
                    inputs,
                    offsets: vec![0, 1],
                    targets: vec![(0, 0)],
                    wt,
                    canonical: (0..n_out as u32).collect(),
                    pool_to: Vec::new(),
                }
            }
            CoreOp::Conv { out_channels: oc, kernel: [kh, kw], stride, padding } => {
                let mut wt = vec![0; oc * ic * kh * kw];
                for o in 0..oc {
                    for ci in 0..ic {
                        for k in 0..kh * kw {
                            wt[(ci * kh * kw + k) * oc + o] = core.weights[(o * ic + ci) * kh * kw + k] as i32;
                        }
                    }
                }
                let (mut offsets, mut targets) = (vec![0u32], Vec::new());
                for y in 0..ih {
                    for x in 0..iw {
                        crate::engine::conv_positions(y, x, [kh, kw], stride, padding, [h, w], |ky, kx, pos| {
                            targets.push(((pos * oc) as u32, ((ky * kw + kx) * oc) as u32));
                        });
                        offsets.push(targets.len() as u32);
                    }
                }
                let plane = ih * iw;
                let inputs = (0..n_in)
                    .map(|i| {
                        let (ci, p) = (i / plane, i % plane);
                        let base = ci * kh * kw * oc;
                        let reach = &targets[offsets[p] as usize..offsets[p + 1] as usize];
                        let synops = reach
                            .iter()
                            .map(|&(_, o)| wt[base + o as usize..][..oc].iter().filter(|&&w| w != 0).count())
                            .sum::<usize>();
                        InputFan { pixel: p as u32, weights: base as u32, synops: synops as u32 }
                    })
                    .collect();
                let canonical = (0..h * w).flat_map(|pos| (0..oc).map(move |ch| (ch * h * w + pos) as u32)).collect();
                CoreRun { group: oc, inputs, offsets, targets, wt, canonical, pool_to: Vec::new() }
            }
        };
        let p = core.pool;
        let (oh, ow) = (h / p, w / p);
        run.pool_to = run
            .canonical
            .iter()
            .map(|&j| {
                let j = j as usize;
                let (ch, y, x) = (j / (h * w), (j / w) % h, j % w);
                // beyond the last whole window, as SumPool2d floors
                if y / p >= oh || x / p >= ow { u32::MAX } else { ((ch * oh + y / p) * ow + x / p) as u32 }
            })
            .collect();
        debug_assert_eq!(run.canonical.len(), c * h * w);
        run
    }

    /// Adds `n` events of input `pre` to the membranes; with `Some(touched)`, each group reached
    /// for the first time this step (`touched.1` per group) is listed (by its first neuron).
    #[inline]
    fn fan_in(&self, v: &mut [i32], pre: usize, n: i32, touched: Option<(&mut Vec<u32>, &mut [bool])>) {
        let f = self.inputs[pre];
        let reach = &self.targets[self.offsets[f.pixel as usize] as usize..self.offsets[f.pixel as usize + 1] as usize];
        let wt = &self.wt[f.weights as usize..];
        match self.group {
            8 => add_groups::<8>(v, wt, reach, n),
            16 => add_groups::<16>(v, wt, reach, n),
            g => {
                for &(nb, wo) in reach {
                    let (nb, wo) = (nb as usize, wo as usize);
                    for (a, &w) in v[nb..nb + g].iter_mut().zip(&wt[wo..wo + g]) {
                        *a += n * w;
                    }
                }
            }
        }
        if let Some((list, is_touched)) = touched {
            for &(nb, _) in reach {
                let flag = &mut is_touched[nb as usize];
                if !*flag {
                    *flag = true;
                    list.push(nb);
                }
            }
        }
    }
}

/// Adds `n` times the `N` weights at each target's offset to the `N` membranes it names, whole
/// vector registers at a time.
#[inline(always)]
fn add_groups<const N: usize>(v: &mut [i32], wt: &[i32], reach: &[(u32, u32)], n: i32) {
    for &(nb, wo) in reach {
        let (nb, wo) = (nb as usize, wo as usize);
        let a: &mut [i32; N] = (&mut v[nb..nb + N]).try_into().expect("N channels");
        let w: &[i32; N] = (&wt[wo..wo + N]).try_into().expect("N weights");
        if n == 1 {
            for k in 0..N {
                a[k] += w[k];
            }
        } else {
            for k in 0..N {
                a[k] += n * w[k];
            }
        }
    }
}

/// A [`SpeckSpec`] ready to run, shared by every stream ([`SpeckState`] is each stream's own).
#[derive(Debug, Clone, PartialEq)]
pub struct Speck {
    spec: SpeckSpec,
    runs: Vec<CoreRun>,
}

/// One core's state in one stream.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CoreState {
    /// Membranes in the run's order (a convolution's channel-last; [`Speck::v_mem`] gives them
    /// in PyTorch's order); after a step each is below the threshold and at least
    /// `threshold_low` (16 bits); during a step the input is summed in 32 bits.
    v_mem: Vec<i32>,
    /// This step's spikes per neuron (PyTorch's order, `[channel][y][x]`).
    pub spikes: Vec<u32>,
    /// Groups (by first neuron) that received input this step, and the flags behind the list
    /// (at each group's first neuron).
    touched: Vec<u32>,
    is_touched: Vec<bool>,
    /// Neurons that spiked this step (PyTorch's order; listed in the run's order).
    fired: Vec<u32>,
}

/// One stream's state on Speck (the spec is shared).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SpeckState {
    pub cores: Vec<CoreState>,
    /// Output spikes per output neuron since rest.
    pub out_spike_counts: Vec<u32>,
    pub step: u64,
    pub stats: SpeckStats,
    /// The pooled spikes sent to the next core this step: (input index, count).
    sent: Vec<(u32, u32)>,
    /// Spikes per pooling window while a core's output is pooled (zeros otherwise).
    pooled: Vec<u32>,
}

/// Work done, per stream.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct SpeckStats {
    pub input_events: u64,
    /// Synaptic operations: one weight added to one membrane.
    pub synops: u64,
    /// Spikes of every core's neurons (the last core's included).
    pub spikes: u64,
    /// The same per core.
    pub spikes_per_core: Vec<u64>,
    pub output_spikes: u64,
    /// Neurons updated: every neuron every step in a stepped run; in an event-driven run every
    /// neuron of each group that received input (all channels of a convolution's position, all
    /// outputs of a dense core).
    pub neuron_updates: u64,
}

impl Speck {
    pub fn new(spec: SpeckSpec) -> Result<Speck> {
        spec.validate()?;
        let runs = spec.cores.iter().map(CoreRun::new).collect();
        Ok(Speck { spec, runs })
    }

    pub fn spec(&self) -> &SpeckSpec {
        &self.spec
    }

    /// A stream at rest.
    pub fn state(&self) -> SpeckState {
        let cores = self
            .runs
            .iter()
            .map(|r| {
                let n = r.canonical.len();
                CoreState { v_mem: vec![0; n], spikes: vec![0; n], is_touched: vec![false; n], ..CoreState::default() }
            })
            .collect();
        SpeckState {
            cores,
            out_spike_counts: vec![0; self.spec.n_out()],
            stats: SpeckStats { spikes_per_core: vec![0; self.spec.cores.len()], ..SpeckStats::default() },
            ..SpeckState::default()
        }
    }

    /// Core `k`'s membranes in PyTorch's order (`[channel][y][x]`).
    pub fn v_mem(&self, st: &SpeckState, k: usize) -> Vec<i32> {
        let mut v = vec![0; self.runs[k].canonical.len()];
        for (&j, &x) in self.runs[k].canonical.iter().zip(&st.cores[k].v_mem) {
            v[j as usize] = x;
        }
        v
    }

    /// One step: `channels` (ascending, no repeats) and their event counts are this step's input.
    /// Afterwards each core's `spikes` holds its spikes of the step.
    pub fn step(&self, st: &mut SpeckState, channels: &[u32], events: &[u16], run: Run) -> Result<()> {
        super::check_step_input(channels, events, self.spec.n_in(), st.step)?;
        let mut input = std::mem::take(&mut st.sent);
        input.clear();
        for (&c, &n) in channels.iter().zip(events) {
            if n > 0 {
                input.push((c, n as u32));
                st.stats.input_events += n as u64;
            }
        }
        let last = self.spec.cores.len() - 1;
        let mut pooled = std::mem::take(&mut st.pooled);
        for (k, (core, r)) in self.spec.cores.iter().zip(&self.runs).enumerate() {
            let cs = &mut st.cores[k];
            // 1. the input, summed in 32 bits (integer sums: the order of events does not matter)
            let mut synops = 0u64;
            for &(pre, n) in &input {
                match run {
                    Run::Stepped => r.fan_in(&mut cs.v_mem, pre as usize, n as i32, None),
                    Run::EventDriven => {
                        r.fan_in(&mut cs.v_mem, pre as usize, n as i32, Some((&mut cs.touched, &mut cs.is_touched)))
                    }
                }
                synops += n as u64 * r.inputs[pre as usize].synops as u64;
            }
            st.stats.synops += synops;
            // 2. the neurons
            for &j in &cs.fired {
                cs.spikes[j as usize] = 0;
            }
            cs.fired.clear();
            let (th, low, zero) = (core.threshold as i32, core.threshold_low as i32, core.return_to_zero);
            let mut fired_spikes = 0u64;
            input.clear();
            let n_next = core.out_shape().iter().product();
            if pooled.len() < n_next {
                pooled.resize(n_next, 0);
            }
            let mut emit = |j: usize, n: u32, cs_spikes: &mut [u32], fired: &mut Vec<u32>| {
                let c = r.canonical[j];
                cs_spikes[c as usize] = n;
                fired.push(c);
                fired_spikes += n as u64;
                let t = r.pool_to[j];
                if t != u32::MAX {
                    // `pooled` is all zeros between uses: each window's count is taken back out
                    if pooled[t as usize] == 0 {
                        input.push((t, 0));
                    }
                    pooled[t as usize] += n;
                }
            };
            let CoreState { v_mem, spikes, touched, is_touched, fired } = cs;
            match run {
                Run::Stepped => {
                    const CHUNK: usize = 16;
                    for (c, chunk) in v_mem.chunks_mut(CHUNK).enumerate() {
                        // most neurons neither fire nor reach the floor: one test per chunk
                        if !chunk.iter().fold(false, |a, &x| a | (x >= th) | (x < low)) {
                            continue;
                        }
                        for (i, v) in chunk.iter_mut().enumerate() {
                            let n = fire(v, th, low, zero);
                            if n > 0 {
                                emit(c * CHUNK + i, n, spikes, fired);
                            }
                        }
                    }
                    st.stats.neuron_updates += v_mem.len() as u64;
                }
                Run::EventDriven => {
                    let g = r.group;
                    for &nb in touched.iter() {
                        let nb = nb as usize;
                        is_touched[nb] = false;
                        let group = &mut v_mem[nb..nb + g];
                        if !group.iter().fold(false, |a, &x| a | (x >= th) | (x < low)) {
                            continue;
                        }
                        for (i, v) in group.iter_mut().enumerate() {
                            let n = fire(v, th, low, zero);
                            if n > 0 {
                                emit(nb + i, n, spikes, fired);
                            }
                        }
                    }
                    st.stats.neuron_updates += (touched.len() * g) as u64;
                }
            }
            touched.clear();
            st.stats.spikes += fired_spikes;
            st.stats.spikes_per_core[k] += fired_spikes;
            // 3. the pooled spikes are the next core's input (integer sums need no order)
            for (t, n) in input.iter_mut() {
                *n = std::mem::take(&mut pooled[*t as usize]);
            }
            if k == last {
                input.sort_unstable();
                st.stats.output_spikes += input.iter().map(|&(_, n)| n as u64).sum::<u64>();
                for &(j, n) in &input {
                    st.out_spike_counts[j as usize] += n;
                }
            }
        }
        st.sent = input;
        st.pooled = pooled;
        st.step += 1;
        Ok(())
    }

    /// A stream's readout since rest: the output spikes counted, per output neuron.
    pub fn readout(&self, st: &SpeckState) -> Vec<f32> {
        st.out_spike_counts.iter().map(|&c| c as f32).collect()
    }

    /// A whole sample from rest: per step, its input channels and their events. Returns the
    /// readout and the stream's work.
    pub fn run_sample<'a>(
        &self,
        steps: impl IntoIterator<Item = (&'a [u32], &'a [u16])>,
        run: Run,
    ) -> Result<(Vec<f32>, SpeckStats)> {
        let mut st = self.state();
        for (channels, events) in steps {
            self.step(&mut st, channels, events, run)?;
        }
        Ok((self.readout(&st), st.stats))
    }
}

impl CoreState {
    /// The neurons that spiked in the last step (PyTorch's order; their counts in `spikes`).
    pub fn fired(&self) -> &[u32] {
        &self.fired
    }
}

impl SpeckState {
    /// The last core's spikes of the last step, pooled: (output neuron, spikes), ascending.
    pub fn last_out_spikes(&self) -> &[(u32, u32)] {
        &self.sent
    }
}

/// Sinabs's IAF step after the input: `MultiSpike`, the reset, the floor. Returns the spikes.
#[inline]
fn fire(v: &mut i32, threshold: i32, low: i32, return_to_zero: bool) -> u32 {
    // `v / threshold` is positive exactly when `v >= threshold > 0`; a neuron that fires is left
    // at or above zero, above the floor
    if *v >= threshold {
        let n = *v / threshold;
        *v = if return_to_zero { 0 } else { *v - n * threshold };
        n as u32
    } else {
        if *v < low {
            *v = low;
        }
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neuron::NeuronParams;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn discretization_scale_is_sinabs() {
        // max 0.5 decides: 127 / 0.5
        assert_eq!(discretization_scale([-0.25, 0.5], 8), 254.0);
        // min -1 decides (|-1| > 0.5 * 128/127): 128 / 1
        assert_eq!(discretization_scale([-1.0, 0.5], 8), 128.0);
        // -0.5 against 0.5: |-0.5| <= 0.5 * 128/127, the positive end decides
        assert_eq!(discretization_scale([-0.5, 0.5], 8), 254.0);
        assert_eq!(discretization_scale([0.0, 0.0], 8), 1.0);
    }

    #[test]
    fn fire_is_multispike_with_either_reset_and_the_floor() {
        let mut v = 250;
        assert_eq!(fire(&mut v, 100, -1000, false), 2);
        assert_eq!(v, 50);
        let mut v = 250;
        assert_eq!(fire(&mut v, 100, -1000, true), 2);
        assert_eq!(v, 0);
        let mut v = 99;
        assert_eq!(fire(&mut v, 100, -1000, false), 0);
        assert_eq!(v, 99);
        let mut v = -5000;
        assert_eq!(fire(&mut v, 100, -1000, false), 0);
        assert_eq!(v, -1000);
    }

    /// 2x8x8 -> conv 3x3 (4, padded) -> IF -> sum-pool 2 -> conv 3x3 (3, stride 2) -> IF -> dense 5 IF.
    fn random_net(seed: u64, reset: Reset) -> Network {
        random_net_with(seed, reset, [4, 3])
    }

    /// The same with `channels` in the convolutions (8 and 16 take the run's vector paths).
    fn random_net_with(seed: u64, reset: Reset, channels: [usize; 2]) -> Network {
        let p = NeuronParams::integrate_and_fire().with_reset(reset);
        super::super::test_nets::conv_pool_dense_with(seed, [p; 3], false, channels)
    }

    fn random_input(rng: &mut ChaCha8Rng, n_in: usize, steps: usize) -> Vec<(Vec<u32>, Vec<u16>)> {
        (0..steps)
            .map(|_| {
                let mut ch: Vec<u32> = (0..n_in as u32).filter(|_| rng.random_bool(0.15)).collect();
                ch.dedup();
                let ev = ch.iter().map(|_| rng.random_range(1..4u16)).collect();
                (ch, ev)
            })
            .collect()
    }

    #[test]
    fn event_driven_is_stepped_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for (seed, reset, channels) in [
            (1, Reset::Zero, [4, 3]),
            (2, Reset::Subtract, [4, 3]),
            (3, Reset::Zero, [8, 16]),
            (4, Reset::Subtract, [16, 8]),
        ] {
            let net = random_net_with(seed, reset, channels);
            let chip = map(&net).unwrap().spec.compile().unwrap();
            let steps = random_input(&mut rng, 128, 40);
            let mut a = chip.state();
            let mut b = chip.state();
            let mut spikes = 0;
            for (c, e) in &steps {
                chip.step(&mut a, c, e, Run::Stepped).unwrap();
                chip.step(&mut b, c, e, Run::EventDriven).unwrap();
                for (x, y) in a.cores.iter().zip(&b.cores) {
                    assert_eq!(x.v_mem, y.v_mem);
                    assert_eq!(x.fired.len(), y.fired.len());
                    assert_eq!(x.spikes, y.spikes);
                }
                spikes = a.stats.spikes;
            }
            assert!(spikes > 0, "the test network spikes");
            assert_eq!(a.out_spike_counts, b.out_spike_counts);
            assert_eq!((a.stats.synops, a.stats.spikes), (b.stats.synops, b.stats.spikes));
            assert!(b.stats.neuron_updates < a.stats.neuron_updates);
        }
    }

    /// The chip's run against a direct dense computation of Sinabs's model on the integer
    /// weights: convolution by its definition, `MultiSpike`, reset, floor, sum pooling; and its
    /// synaptic operations, one per event and non-zero weight reached (every seventh weight is set
    /// to zero).
    #[test]
    fn equals_sinabs_model_computed_densely() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for (reset, channels) in [(Reset::Zero, [4, 3]), (Reset::Subtract, [4, 3]), (Reset::Subtract, [8, 16])] {
            let net = random_net_with(9, reset, channels);
            let mut spec = map(&net).unwrap().spec;
            for core in &mut spec.cores {
                core.weights.iter_mut().step_by(7).for_each(|w| *w = 0);
            }
            let chip = spec.clone().compile().unwrap();
            let steps = random_input(&mut rng, 128, 30);
            let mut st = chip.state();
            let mut synops = 0;
            let mut v: Vec<Vec<i64>> = spec.cores.iter().map(|c| vec![0; c.neuron_shape().iter().product()]).collect();
            for (ch, ev) in &steps {
                chip.step(&mut st, ch, ev, Run::EventDriven).unwrap();
                let mut x = vec![0i64; spec.n_in()];
                for (&c, &n) in ch.iter().zip(ev) {
                    x[c as usize] = n as i64;
                }
                for (k, core) in spec.cores.iter().enumerate() {
                    let [ic, ih, iw] = core.in_shape;
                    let [oc, oh, ow] = core.neuron_shape();
                    let mut s = vec![0i64; oc * oh * ow];
                    for o in 0..oc * oh * ow {
                        let sum: i64 = match core.op {
                            CoreOp::Dense { .. } => (0..x.len())
                                .map(|i| {
                                    let w = core.weights[o * x.len() + i] as i64;
                                    synops += if w != 0 { x[i] } else { 0 };
                                    x[i] * w
                                })
                                .sum(),
                            CoreOp::Conv { kernel, stride, padding, .. } => {
                                let (c_out, oy, ox) = (o / (oh * ow), (o / ow) % oh, o % ow);
                                let mut acc = 0;
                                for c in 0..ic {
                                    for ky in 0..kernel[0] {
                                        for kx in 0..kernel[1] {
                                            let y = (oy * stride[0] + ky) as i64 - padding[0] as i64;
                                            let xx = (ox * stride[1] + kx) as i64 - padding[1] as i64;
                                            if y < 0 || xx < 0 || y >= ih as i64 || xx >= iw as i64 {
                                                continue;
                                            }
                                            let w = core.weights[((c_out * ic + c) * kernel[0] + ky) * kernel[1] + kx]
                                                as i64;
                                            let xi = x[(c * ih + y as usize) * iw + xx as usize];
                                            synops += if w != 0 { xi } else { 0 };
                                            acc += w * xi;
                                        }
                                    }
                                }
                                acc
                            }
                        };
                        let vm = &mut v[k][o];
                        *vm += sum;
                        let n = if *vm > 0 { *vm / core.threshold as i64 } else { 0 };
                        if n > 0 {
                            *vm = if core.return_to_zero { 0 } else { *vm - n * core.threshold as i64 };
                        }
                        *vm = (*vm).max(core.threshold_low as i64);
                        s[o] = n;
                    }
                    assert_eq!(
                        chip.v_mem(&st, k).iter().map(|&a| a as i64).collect::<Vec<_>>(),
                        v[k],
                        "core {k}, {reset:?}"
                    );
                    let p = core.pool;
                    let [pc, ph, pw] = core.out_shape();
                    let mut y = vec![0i64; pc * ph * pw];
                    for c in 0..pc {
                        for a in 0..ph * p {
                            for b in 0..pw * p {
                                y[(c * ph + a / p) * pw + b / p] += s[(c * oh + a) * ow + b];
                            }
                        }
                    }
                    x = y;
                }
                assert_eq!(st.stats.synops, synops as u64, "{reset:?} {channels:?}");
            }
            assert!(st.stats.spikes > 0);
        }
    }

    #[test]
    fn refuses_what_speck_cannot_hold() {
        let mut net = random_net(1, Reset::Zero);
        net.layers[0].neurons = Some(NeuronParams::lif(0.9));
        let e = map(&net).unwrap_err().to_string();
        assert!(e.contains("Speck") && e.contains("IF"), "{e}");
        let mut net = random_net(1, Reset::Zero);
        if let Op::Pool { kind, .. } = &mut net.layers[1].op {
            *kind = PoolKind::Avg;
        }
        let e = map(&net).unwrap_err().to_string();
        assert!(e.contains("summing"), "{e}");
    }

    #[test]
    fn weights_take_one_scale_per_core_and_fit_eight_bits() {
        let net = random_net(4, Reset::Subtract);
        let m = map(&net).unwrap();
        for (core, layer) in m.spec.cores.iter().zip(net.layers.iter().filter(|l| l.neurons.is_some())) {
            let (Op::Conv2d { weight: w, .. } | Op::Dense { weight: w, .. }) = &layer.op else {
                unreachable!("a spiking layer of the test network has weights")
            };
            let top = w.iter().fold(0.0f32, |a, &b| a.max(b.abs()));
            assert!(core.weights.iter().any(|&q| q == 127 || q == -128), "the largest weight reaches the range");
            assert_eq!(core.threshold, (1.0 * core.scale).round() as i16);
            assert!((core.scale * top - 127.0).abs() < 1.5, "{} {top}", core.scale);
        }
    }
}
