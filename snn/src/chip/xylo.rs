//! Xylo Audio 2 (SYNS61201) as it computes, after XyloSim v2 (PyPI `xylosim` 0.1.3,
//! `src/v2/cpp/XyloIAFNeuron.cpp`, `XyloLayer.cpp`), the bit-exact simulator Rockpool's `XyloSim`
//! runs. Per step:
//!
//! 1. input events (at most 15 per channel) reach the hidden neurons' synaptic currents:
//!    `i = sat16(i + (w_in << shift_in))` once per event, channels ascending, targets ascending;
//! 2. the hidden spikes of the previous step (at most 31 per neuron) reach the hidden neurons
//!    through `w_rec` and the output neurons through `w_out`, the same way;
//! 3. every neuron: `i -= decay(i, dash_syn)`; `dv = sat16(-decay(v, dash_mem) + i)`;
//!    `v = sat16(v + dv)`; then while `v >= threshold` (up to 31 spikes, 1 for an output
//!    neuron) a spike and `v -= threshold`.
//!
//! `decay(x, dash) = x >> dash` (arithmetic shift), or `sign(x)` if that is zero. Weights are 8-bit
//! signed, state and thresholds 16-bit signed, `dash` 4 bits. `sat16` is XyloSim's `safe_add`.
//!
//! The event-driven run ([`Run::EventDriven`]) updates only neurons with a non-zero state or an
//! input this step; a neuron at rest with a positive threshold stays at rest and silent, so it
//! is the stepped run bit for bit (tested).
//!
//! [`map`] turns a trained network into a [`XyloSpec`] (the specification Rockpool's mapper
//! produces: `weights_in`, `weights_rec`, `weights_out`, `dash_*`, `threshold*`,
//! `weight_shift_*`), naming each [`Approximation`] it had to make.

use super::{Chip, ChipReset, DecayArithmetic, NumberFormat};
use crate::error::{Error, Result};
use crate::network::{Network, Op};
use crate::neuron::{NeuronKind, NeuronParams};
use serde::{Deserialize, Serialize};

/// Xylo Audio 2's number formats.
pub const FORMAT: NumberFormat = NumberFormat {
    weight_bits: 8,
    max_weight_shift: MAX_WEIGHT_SHIFT,
    state_bits: 16,
    threshold_bits: 16,
    decay: DecayArithmetic::BitShift { bits: 4 },
    reset: ChipReset::Subtract,
    max_spikes_per_step: Some(MAX_SPIKES),
    max_output_spikes_per_step: Some(MAX_OUT_SPIKES),
    max_input_events_per_step: Some(MAX_INPUT_EVENTS),
    source: "XyloSim v2 (PyPI xylosim 0.1.3: src/v2/cpp/XyloIAFNeuron.h BITS_STATE 16, BITS_WEIGHT 8, MAX_NUM_INP_SPIKES 15, MAX_NUM_SPIKES 31, MAX_NUM_OUT_SPIKES 1; dash 4 bits), run by Rockpool 3.1's XyloSim for SYNS61201",
};

const MAX_INPUT_EVENTS: u8 = 15;
const MAX_SPIKES: u8 = 31;
const MAX_OUT_SPIKES: u8 = 1;
/// A shifted 8-bit weight still fits the 16-bit state (`-128 << 8 = -32768`).
const MAX_WEIGHT_SHIFT: u8 = 8;
const MAX_DASH: u8 = 15;
/// The mapper's default ceiling on hidden thresholds, in bits: thresholds at most 2^9, which
/// leaves 6 bits of the 16-bit state above them for summed currents (the trained models' currents
/// reach several thresholds per step). Chosen on the raw1350 train split, the best of 2^8..2^14
/// there (2^8 and 2^9 tie at 65.71%, 2^13 54.64%; the larger of the tie for resolution):
/// `cargo run --release -p experiments --example xylo_differences`. For the Xylo model it means
/// no weight shift, as Rockpool's quantisers leave it.
pub const THRESHOLD_BITS: u8 = 9;

/// How float weights become 8-bit integers (Rockpool's `global_quantize` and `channel_quantize`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Quantisation {
    /// One scale for all input and recurrent weights, one for the output weights.
    Global,
    /// One scale per target neuron (its input and recurrent weights together; each output
    /// neuron's own), its threshold scaled with it.
    Channel,
}

/// How the run visits neurons.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Run {
    /// Every neuron, every step (XyloSim's loop).
    Stepped,
    /// Only neurons with a non-zero state or input this step.
    EventDriven,
}

/// What the network reads out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum XyloReadout {
    /// The output neurons never fire (threshold at the top of the state's range); the class is
    /// the highest membrane over the steps, read as Rockpool's `output_mode="Vmem"` reads it.
    MaxMembrane,
    /// The output neurons' spikes, counted.
    SpikeCount,
}

impl From<crate::model_file::Readout> for XyloReadout {
    /// The chip reads out as the model file says.
    fn from(r: crate::model_file::Readout) -> Self {
        match r {
            crate::model_file::Readout::MaxMembrane => XyloReadout::MaxMembrane,
            crate::model_file::Readout::SpikeCount => XyloReadout::SpikeCount,
        }
    }
}

/// Something of the float network Xylo cannot hold as it is, and what the mapping made of it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Approximation {
    /// A decay per step rounded to Xylo's `1 - 2^-dash`.
    Decay { layer: usize, state: &'static str, float: f32, chip: f32, dash: u8 },
    /// A LIF layer without a synaptic current: Xylo's synapse with the fastest decay
    /// (`dash_syn` 1: half the current each step) spreads each input over the following steps,
    /// its sum unchanged.
    FastSynapse { layer: usize },
    /// Reset to zero: Xylo subtracts the threshold, and may send several spikes per step.
    ResetBySubtraction { layer: usize },
    /// Layer `layer`'s input arrives one step later than in the float network: Xylo passes
    /// hidden spikes on (to the next hidden layer or to the outputs) at the next step.
    OneStepDelay { layer: usize },
    /// Input counts above 15 per channel and step are cut to 15.
    InputEventsCapped,
}

impl std::fmt::Display for Approximation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Approximation::Decay { layer, state, float, chip, dash } => {
                write!(f, "layer {layer}: {state} decay {float:.4} per step becomes {chip:.4} (dash {dash})")
            }
            Approximation::FastSynapse { layer } => {
                write!(f, "layer {layer}: LIF input passes through Xylo's synapse at its fastest decay (dash 1)")
            }
            Approximation::ResetBySubtraction { layer } => {
                write!(f, "layer {layer}: reset to zero becomes subtraction of the threshold")
            }
            Approximation::OneStepDelay { layer } => write!(f, "layer {layer}: input one step later"),
            Approximation::InputEventsCapped => write!(f, "input events above 15 per channel and step are dropped"),
        }
    }
}

/// A network in Xylo's formats: the specification Rockpool's mapper and quantisers produce, with
/// Rockpool's names and layouts (`weights_in[input][hidden]`, `weights_rec[hidden][hidden]`,
/// `weights_out[hidden][output]`, one synapse per neuron).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct XyloSpec {
    pub n_in: usize,
    pub n_hidden: usize,
    pub n_out: usize,
    pub weights_in: Vec<i8>,
    pub weights_rec: Vec<i8>,
    pub weights_out: Vec<i8>,
    pub weight_shift_in: u8,
    pub weight_shift_rec: u8,
    pub weight_shift_out: u8,
    pub dash_mem: Vec<u8>,
    pub dash_syn: Vec<u8>,
    pub dash_mem_out: Vec<u8>,
    pub dash_syn_out: Vec<u8>,
    pub threshold: Vec<i16>,
    pub threshold_out: Vec<i16>,
    pub readout: XyloReadout,
    /// The first hidden neuron of each hidden layer of the float network, and the count.
    pub hidden_layers: Vec<(usize, usize)>,
}

/// A mapped network and what the mapping changed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Mapped {
    pub spec: XyloSpec,
    pub quantisation: Quantisation,
    pub approximations: Vec<Approximation>,
    pub scales: StateScales,
}

/// Chip state units per unit of the float network's state, per neuron: the quantiser's scale
/// times `2^weight_shift`. A chip membrane over its neuron's scale is the float membrane it
/// stands for (a threshold too); quantisation-aware training reads the chip's states through
/// them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StateScales {
    pub hidden: Vec<f32>,
    pub out: Vec<f32>,
}

fn cannot(layer: Option<usize>, what: impl Into<String>) -> Error {
    Error::Chip { chip: Chip::Xylo, layer, what: what.into() }
}

/// Xylo's `dash` for a decay per step: Rockpool's `round(log2(tau / dt))` with
/// `tau / dt = -1 / ln(decay)`, within the register's 1..=15 (0 would clear the state each step).
pub fn dash_of(decay: f32) -> u8 {
    if decay <= 0.0 {
        return 1;
    }
    if decay >= 1.0 {
        return MAX_DASH;
    }
    let tau_steps = -1.0 / (decay as f64).ln();
    tau_steps.log2().round().clamp(1.0, MAX_DASH as f64) as u8
}

/// `1 - 2^-dash`: the decay a `dash` gives, for values far from zero.
pub fn decay_of(dash: u8) -> f32 {
    1.0 - 0.5f32.powi(dash as i32)
}

/// `p` with Xylo's decays (`1 - 2^-dash`, [`dash_of`]) and, for spiking neurons, its reset by
/// subtraction: a float network of these neurons leaks and resets as the chip does.
pub fn neurons(p: NeuronParams) -> NeuronParams {
    use crate::neuron::Reset;
    let mut q = p;
    if p.kind == NeuronKind::If {
        return q;
    }
    q.beta = decay_of(dash_of(p.beta));
    if p.kind == NeuronKind::CubaLif {
        q.alpha = decay_of(dash_of(p.alpha));
    }
    if p.kind != NeuronKind::Li {
        q.reset = Reset::Subtract;
    }
    q
}

/// One float layer ready for quantisation: weights in Xylo's `[pre][post]` layout, already
/// scaled for Xylo's synapse.
struct FloatLayer {
    n_in: usize,
    n_out: usize,
    /// `[pre][post]`
    weight: Vec<f32>,
    recurrent: Option<Vec<f32>>,
    dash_mem: u8,
    dash_syn: u8,
    v_th: f32,
}

/// Maps a trained network onto Xylo: dense layers only, no biases, no resting level or reset
/// level other than zero; every layer but the last spiking (LIF or CubaLIF, optionally
/// recurrent), the last LIF, CubaLIF or a leaky-integrator readout. Hidden layers after the
/// first reach each other through the recurrent weights (one step later each).
///
/// Decays become bit shifts ([`dash_of`]); a CubaLIF layer's weights are divided by Xylo's
/// synaptic decay, because Xylo decays the current after adding the input where the float
/// network (NIR's and snnTorch's order) adds it after; then the weights are quantised to 8 bits
/// as Rockpool quantises them, and shifted left by the largest shift that keeps every hidden
/// threshold at most 2^[`THRESHOLD_BITS`] (the state's resolution, where Rockpool leaves the
/// shifts at zero).
pub fn map(net: &Network, quantisation: Quantisation) -> Result<Mapped> {
    map_with(net, quantisation, THRESHOLD_BITS)
}

/// [`map`] with hidden thresholds at most `2^threshold_bits` (at most 14).
pub fn map_with(net: &Network, quantisation: Quantisation, threshold_bits: u8) -> Result<Mapped> {
    if threshold_bits > 14 {
        return Err(cannot(None, format!("thresholds of up to 2^{threshold_bits} leave no room in 16 bits")));
    }
    net.validate()?;
    let last = net.layers.len() - 1;
    if last == 0 {
        return Err(cannot(Some(0), "Xylo's inputs feed hidden neurons only: the network needs a hidden layer"));
    }
    let mut approximations = Vec::new();
    let mut layers = Vec::new();
    for (k, l) in net.layers.iter().enumerate() {
        let Op::Dense { n_in, n_out, weight, bias } = &l.op else {
            return Err(cannot(Some(k), "Xylo has dense (and recurrent) layers only"));
        };
        if bias.is_some() || l.recurrent_bias.is_some() {
            return Err(cannot(Some(k), "the model has a bias; this mapping takes bias-free models"));
        }
        let Some(p) = l.neurons else {
            return Err(cannot(Some(k), "every layer needs neurons on Xylo"));
        };
        check_neurons(k, &p, k == last)?;
        if k == last && l.recurrent.is_some() {
            return Err(cannot(Some(k), "Xylo's output neurons have no recurrent input"));
        }
        let dash_mem = dash_of(p.beta);
        if decay_of(dash_mem) != p.beta {
            approximations.push(Approximation::Decay {
                layer: k,
                state: "membrane",
                float: p.beta,
                chip: decay_of(dash_mem),
                dash: dash_mem,
            });
        }
        let (dash_syn, gain) = match p.kind {
            NeuronKind::CubaLif => {
                let d = dash_of(p.alpha);
                if decay_of(d) != p.alpha {
                    approximations.push(Approximation::Decay {
                        layer: k,
                        state: "synaptic current",
                        float: p.alpha,
                        chip: decay_of(d),
                        dash: d,
                    });
                }
                (d, 1.0 / decay_of(d))
            }
            _ => {
                approximations.push(Approximation::FastSynapse { layer: k });
                (1, 1.0)
            }
        };
        if p.kind != NeuronKind::Li && p.reset == crate::neuron::Reset::Zero {
            approximations.push(Approximation::ResetBySubtraction { layer: k });
        }
        if k > 0 {
            approximations.push(Approximation::OneStepDelay { layer: k });
        }
        let mut w = vec![0.0f32; n_in * n_out];
        for o in 0..*n_out {
            for i in 0..*n_in {
                w[i * n_out + o] = weight[o * n_in + i] * gain;
            }
        }
        let recurrent = l.recurrent.as_ref().map(|r| {
            let n = *n_out;
            let mut t = vec![0.0f32; n * n];
            for o in 0..n {
                for i in 0..n {
                    t[i * n + o] = r[o * n + i] * gain;
                }
            }
            t
        });
        let v_th = if p.kind == NeuronKind::Li { f32::INFINITY } else { p.v_th };
        layers.push(FloatLayer { n_in: *n_in, n_out: *n_out, weight: w, recurrent, dash_mem, dash_syn, v_th });
    }
    approximations.push(Approximation::InputEventsCapped);
    let readout = if net.layers[last].neurons.is_some_and(|p| p.kind == NeuronKind::Li) {
        XyloReadout::MaxMembrane
    } else {
        XyloReadout::SpikeCount
    };
    let (spec, scales) = quantise(&layers, readout, quantisation, 1i32 << threshold_bits)?;
    spec.validate()?;
    Ok(Mapped { spec, quantisation, approximations, scales })
}

fn check_neurons(k: usize, p: &NeuronParams, last: bool) -> Result<()> {
    match p.kind {
        NeuronKind::If => return Err(cannot(Some(k), "Xylo's membranes always leak: IF neurons have no Xylo form")),
        NeuronKind::Li if !last => return Err(cannot(Some(k), "a leaky integrator is a readout: the last layer only")),
        _ => {}
    }
    if p.v_leak != 0.0 {
        return Err(cannot(Some(k), format!("Xylo's membranes rest at zero; this layer's rest at {}", p.v_leak)));
    }
    if p.kind != NeuronKind::Li && p.v_reset != 0.0 {
        return Err(cannot(Some(k), format!("Xylo resets by subtraction; this layer resets to {}", p.v_reset)));
    }
    if p.kind != NeuronKind::Li && p.v_th <= 0.0 {
        return Err(cannot(Some(k), format!("Xylo's thresholds are positive here; this layer's is {}", p.v_th)));
    }
    Ok(())
}

fn round_i8(x: f32) -> i8 {
    x.round().clamp(-128.0, 127.0) as i8
}

/// Rockpool's quantisers on the float layers, then the weight shift.
fn quantise(
    layers: &[FloatLayer],
    readout: XyloReadout,
    q: Quantisation,
    ceiling: i32,
) -> Result<(XyloSpec, StateScales)> {
    let (hidden, out) = layers.split_at(layers.len() - 1);
    let out = &out[0];
    let n_in = hidden[0].n_in;
    let n_hidden: usize = hidden.iter().map(|l| l.n_out).sum();
    let n_out = out.n_out;
    // the float weights in Xylo's matrices
    let mut w_in = vec![0.0f32; n_in * n_hidden];
    let mut w_rec = vec![0.0f32; n_hidden * n_hidden];
    let mut w_out = vec![0.0f32; n_hidden * n_out];
    let mut starts = Vec::new();
    let mut start = 0;
    for (k, l) in hidden.iter().enumerate() {
        starts.push((start, l.n_out));
        if k == 0 {
            for i in 0..n_in {
                for o in 0..l.n_out {
                    w_in[i * n_hidden + o] = l.weight[i * l.n_out + o];
                }
            }
        } else {
            let (prev, prev_n) = starts[k - 1];
            for i in 0..prev_n {
                for o in 0..l.n_out {
                    w_rec[(prev + i) * n_hidden + start + o] = l.weight[i * l.n_out + o];
                }
            }
        }
        if let Some(r) = &l.recurrent {
            for i in 0..l.n_out {
                for o in 0..l.n_out {
                    w_rec[(start + i) * n_hidden + start + o] = r[i * l.n_out + o];
                }
            }
        }
        start += l.n_out;
    }
    let (last_start, last_n) = *starts.last().unwrap_or(&(0, 0));
    for i in 0..last_n {
        for o in 0..n_out {
            w_out[(last_start + i) * n_out + o] = out.weight[i * n_out + o];
        }
    }
    let mut v_th = Vec::with_capacity(n_hidden);
    let (mut dash_mem, mut dash_syn) = (Vec::with_capacity(n_hidden), Vec::with_capacity(n_hidden));
    for l in hidden {
        v_th.extend(std::iter::repeat_n(l.v_th, l.n_out));
        dash_mem.extend(std::iter::repeat_n(l.dash_mem, l.n_out));
        dash_syn.extend(std::iter::repeat_n(l.dash_syn, l.n_out));
    }
    // per target neuron: the scale that takes its largest incoming weight to 127
    let max_abs = |it: &mut dyn Iterator<Item = f32>| it.fold(0.0f32, |m, w| m.max(w.abs()));
    let hidden_scale: Vec<f32> = match q {
        Quantisation::Global => {
            let m = max_abs(&mut w_in.iter().chain(&w_rec).copied());
            vec![if m > 0.0 { 127.0 / m } else { 1.0 }; n_hidden]
        }
        Quantisation::Channel => (0..n_hidden)
            .map(|o| {
                let m = max_abs(
                    &mut (0..n_in)
                        .map(|i| w_in[i * n_hidden + o])
                        .chain((0..n_hidden).map(|i| w_rec[i * n_hidden + o])),
                );
                if m > 0.0 { 127.0 / m } else { 1.0 }
            })
            .collect(),
    };
    let out_scale: Vec<f32> = match q {
        Quantisation::Global => {
            let m = max_abs(&mut w_out.iter().copied());
            vec![if m > 0.0 { 127.0 / m } else { 1.0 }; n_out]
        }
        Quantisation::Channel => (0..n_out)
            .map(|o| {
                let m = max_abs(&mut (0..n_hidden).map(|i| w_out[i * n_out + o]));
                if m > 0.0 { 127.0 / m } else { 1.0 }
            })
            .collect(),
    };
    // a threshold beyond 16 bits lowers its scale until it fits, as Rockpool's quantisers do
    // (per neuron, or for all at once with one scale; Rockpool rounds the weights a second time
    // there, this scales once)
    let limit = |scale: &mut [f32], th: &dyn Fn(usize) -> f32, global: bool| {
        let fits = |t: f32, s: f32| !t.is_finite() || t * s <= i16::MAX as f32;
        if global {
            let top = (0..scale.len()).map(th).filter(|t| t.is_finite()).fold(0.0f32, f32::max);
            if (0..scale.len()).any(|o| !fits(th(o), scale[o])) {
                scale.iter_mut().for_each(|s| *s = i16::MAX as f32 / top);
            }
        } else {
            for (o, s) in scale.iter_mut().enumerate() {
                if !fits(th(o), *s) {
                    *s = i16::MAX as f32 / th(o);
                }
            }
        }
    };
    let mut hidden_scale = hidden_scale;
    let mut out_scale = out_scale;
    let global = q == Quantisation::Global;
    limit(&mut hidden_scale, &|o| v_th[o], global);
    limit(&mut out_scale, &|_| out.v_th, global);
    // the shift: the largest that keeps every hidden threshold under the ceiling
    let th_hidden: Vec<f32> = v_th.iter().zip(&hidden_scale).map(|(t, s)| t * s).collect();
    let shift_for = |ths: &[f32]| -> Result<u8> {
        let top = ths.iter().copied().filter(|t| t.is_finite()).fold(0.0f32, f32::max);
        if top.round() > i16::MAX as f32 {
            return Err(cannot(None, format!("a threshold of {top:.0} weight units does not fit 16 bits")));
        }
        let mut s = 0u8;
        while s < MAX_WEIGHT_SHIFT && top * (1u32 << (s + 1)) as f32 <= ceiling as f32 {
            s += 1;
        }
        Ok(s)
    };
    let shift_hidden = shift_for(&th_hidden)?;
    let th_out: Vec<f32> = out_scale.iter().map(|s| out.v_th * s).collect();
    let shift_out = match readout {
        // the membrane only needs to rank the classes: no shift, so it does not saturate
        XyloReadout::MaxMembrane => 0,
        XyloReadout::SpikeCount => shift_for(&th_out)?,
    };
    let int_th = |t: f32, shift: u8| -> i16 {
        if t.is_finite() { (t * (1u32 << shift) as f32).round().clamp(1.0, i16::MAX as f32) as i16 } else { i16::MAX }
    };
    let scales = StateScales {
        hidden: hidden_scale.iter().map(|s| s * (1u32 << shift_hidden) as f32).collect(),
        out: out_scale.iter().map(|s| s * (1u32 << shift_out) as f32).collect(),
    };
    let spec = XyloSpec {
        n_in,
        n_hidden,
        n_out,
        weights_in: (0..n_in * n_hidden).map(|j| round_i8(w_in[j] * hidden_scale[j % n_hidden])).collect(),
        weights_rec: (0..n_hidden * n_hidden).map(|j| round_i8(w_rec[j] * hidden_scale[j % n_hidden])).collect(),
        weights_out: (0..n_hidden * n_out).map(|j| round_i8(w_out[j] * out_scale[j % n_out])).collect(),
        weight_shift_in: shift_hidden,
        weight_shift_rec: shift_hidden,
        weight_shift_out: shift_out,
        dash_mem,
        dash_syn,
        dash_mem_out: vec![out.dash_mem; n_out],
        dash_syn_out: vec![out.dash_syn; n_out],
        threshold: th_hidden.iter().map(|&t| int_th(t, shift_hidden)).collect(),
        threshold_out: th_out.iter().map(|&t| int_th(t, shift_out)).collect(),
        readout,
        hidden_layers: starts,
    };
    Ok((spec, scales))
}

/// XyloSim's `decay`: `x >> dash`, or one unit towards zero if that is zero.
#[inline]
pub fn decay(x: i16, dash: u8) -> i16 {
    let d = x >> dash;
    if d == 0 { x.signum() } else { d }
}

/// XyloSim's `safe_add` on 16 bits: `x + y`, or the end of the range it would pass.
#[inline]
pub fn safe_add(x: i64, y: i64) -> i64 {
    let max = if y < 0 { i16::MIN as i64 } else { i16::MAX as i64 };
    if (max - x).abs() > y.abs() { x + y } else { max }
}

/// One stream's state on Xylo (the spec is shared).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct XyloState {
    pub i_syn: Vec<i16>,
    pub v_mem: Vec<i16>,
    pub i_syn_out: Vec<i16>,
    pub v_mem_out: Vec<i16>,
    /// Spikes per hidden neuron sent this step (delivered at the next).
    pub spikes: Vec<u8>,
    /// Spikes per output neuron this step.
    pub out_spikes: Vec<u8>,
    /// Per output neuron since rest: the highest membrane after a step (at least zero), and the
    /// spikes; [`Xylo::readout`] reads one of them.
    pub v_mem_out_max: Vec<i16>,
    pub out_spike_counts: Vec<u32>,
    pub step: u64,
    pub stats: XyloStats,
    /// Event-driven bookkeeping: hidden and output neurons to update this step.
    active: Vec<bool>,
    active_list: Vec<u32>,
    active_out: Vec<bool>,
    active_out_list: Vec<u32>,
    fired: Vec<u32>,
}

/// Work done, per stream.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct XyloStats {
    /// Input events taken (after the cap of 15 per channel and step).
    pub input_events: u64,
    /// Synaptic operations: one weight added to one current.
    pub synops: u64,
    pub hidden_spikes: u64,
    pub output_spikes: u64,
    /// Neurons updated (every neuron every step in a stepped run).
    pub neuron_updates: u64,
}

impl XyloSpec {
    /// Checks lengths and ranges: what XyloSim would take.
    pub fn validate(&self) -> Result<()> {
        let (i, h, o) = (self.n_in, self.n_hidden, self.n_out);
        let lens = [
            ("weights_in", self.weights_in.len(), i * h),
            ("weights_rec", self.weights_rec.len(), h * h),
            ("weights_out", self.weights_out.len(), h * o),
            ("dash_mem", self.dash_mem.len(), h),
            ("dash_syn", self.dash_syn.len(), h),
            ("threshold", self.threshold.len(), h),
            ("dash_mem_out", self.dash_mem_out.len(), o),
            ("dash_syn_out", self.dash_syn_out.len(), o),
            ("threshold_out", self.threshold_out.len(), o),
        ];
        if let Some((name, got, want)) = lens.iter().find(|(_, g, w)| g != w) {
            return Err(cannot(None, format!("`{name}` has {got} values, the sizes need {want}")));
        }
        use crate::nir::{XYLO_MAX_HIDDEN, XYLO_MAX_INPUTS, XYLO_MAX_OUTPUTS};
        for (what, n, max) in [
            ("input channels", i, XYLO_MAX_INPUTS),
            ("hidden neurons", h, XYLO_MAX_HIDDEN),
            ("output neurons", o, XYLO_MAX_OUTPUTS),
        ] {
            if n > max {
                return Err(cannot(None, format!("Xylo has at most {max} {what}, the network {n}")));
            }
        }
        if let Some(d) = self
            .dash_mem
            .iter()
            .chain(&self.dash_syn)
            .chain(&self.dash_mem_out)
            .chain(&self.dash_syn_out)
            .find(|&&d| d > MAX_DASH)
        {
            return Err(cannot(None, format!("a dash of {d} does not fit 4 bits")));
        }
        if [self.weight_shift_in, self.weight_shift_rec, self.weight_shift_out].iter().any(|&s| s > MAX_WEIGHT_SHIFT) {
            return Err(cannot(None, format!("weight shifts are at most {MAX_WEIGHT_SHIFT}")));
        }
        if let Some(n) = self.threshold.iter().chain(&self.threshold_out).position(|&t| t <= 0) {
            return Err(cannot(None, format!("threshold {n} is not positive (a neuron at rest would fire)")));
        }
        Ok(())
    }

    /// Ready to run (validated, weights laid out per pre-synaptic neuron).
    pub fn compile(self) -> Result<Xylo> {
        Xylo::new(self)
    }
}

/// Non-zero synapses per pre-synaptic neuron, weights already shifted (XyloSim's synapse lists).
#[derive(Debug, Clone, PartialEq)]
struct Rows {
    start: Vec<u32>,
    post: Vec<u32>,
    weight: Vec<i64>,
}

impl Rows {
    /// `w` is `[pre][post]` with `n_post` columns.
    fn new(w: &[i8], n_post: usize, shift: u8) -> Rows {
        let mut r = Rows { start: vec![0], post: Vec::new(), weight: Vec::new() };
        for row in w.chunks(n_post.max(1)) {
            for (post, &x) in row.iter().enumerate().filter(|(_, x)| **x != 0) {
                r.post.push(post as u32);
                r.weight.push((x as i64) << shift);
            }
            r.start.push(r.post.len() as u32);
        }
        r
    }

    fn of(&self, pre: usize) -> (&[u32], &[i64]) {
        let r = self.start[pre] as usize..self.start[pre + 1] as usize;
        (&self.post[r.clone()], &self.weight[r])
    }
}

/// A [`XyloSpec`] ready to run, shared by every stream ([`XyloState`] is each stream's own).
#[derive(Debug, Clone, PartialEq)]
pub struct Xylo {
    spec: XyloSpec,
    rows_in: Rows,
    rows_rec: Rows,
    rows_out: Rows,
}

impl Xylo {
    pub fn new(spec: XyloSpec) -> Result<Xylo> {
        spec.validate()?;
        Ok(Xylo {
            rows_in: Rows::new(&spec.weights_in, spec.n_hidden, spec.weight_shift_in),
            rows_rec: Rows::new(&spec.weights_rec, spec.n_hidden, spec.weight_shift_rec),
            rows_out: Rows::new(&spec.weights_out, spec.n_out, spec.weight_shift_out),
            spec,
        })
    }

    pub fn spec(&self) -> &XyloSpec {
        &self.spec
    }

    /// A stream at rest.
    pub fn state(&self) -> XyloState {
        XyloState {
            i_syn: vec![0; self.spec.n_hidden],
            v_mem: vec![0; self.spec.n_hidden],
            i_syn_out: vec![0; self.spec.n_out],
            v_mem_out: vec![0; self.spec.n_out],
            spikes: vec![0; self.spec.n_hidden],
            out_spikes: vec![0; self.spec.n_out],
            v_mem_out_max: vec![0; self.spec.n_out],
            out_spike_counts: vec![0; self.spec.n_out],
            active: vec![false; self.spec.n_hidden],
            active_out: vec![false; self.spec.n_out],
            ..XyloState::default()
        }
    }

    /// One step: `channels` and `events` hold this step's input channels (ascending, no repeats)
    /// and their events. Afterwards `st.spikes` and `st.out_spikes` hold this step's spikes and
    /// the states are the chip's after the step.
    pub fn step(&self, st: &mut XyloState, channels: &[u32], events: &[u16], run: Run) -> Result<()> {
        let (h, o) = (self.spec.n_hidden, self.spec.n_out);
        // 1. input events
        super::check_step_input(channels, events, self.spec.n_in, st.step)?;
        for (&c, &n) in channels.iter().zip(events) {
            let c = c as usize;
            let n = n.min(MAX_INPUT_EVENTS as u16);
            if n == 0 {
                continue;
            }
            st.stats.input_events += n as u64;
            deliver(self.rows_in.of(c), n, &mut st.i_syn, &mut st.stats.synops, &mut st.active, &mut st.active_list);
        }
        // 2. last step's hidden spikes, to the hidden and the output neurons
        let fired = std::mem::take(&mut st.fired);
        match run {
            Run::Stepped => (0..h).for_each(|j| self.deliver_spikes_of(st, j)),
            Run::EventDriven => fired.iter().for_each(|&j| self.deliver_spikes_of(st, j as usize)),
        }
        match run {
            Run::Stepped => st.spikes.iter_mut().for_each(|s| *s = 0),
            Run::EventDriven => fired.iter().for_each(|&j| st.spikes[j as usize] = 0),
        }
        st.out_spikes.iter_mut().for_each(|s| *s = 0);
        let mut fired = fired;
        fired.clear();
        // 3. the neurons
        match run {
            Run::Stepped => {
                for j in 0..h {
                    let n = evolve(
                        &mut st.i_syn[j],
                        &mut st.v_mem[j],
                        self.spec.dash_syn[j],
                        self.spec.dash_mem[j],
                        self.spec.threshold[j],
                        MAX_SPIKES,
                    );
                    st.spikes[j] = n;
                    if n > 0 {
                        fired.push(j as u32);
                    }
                }
                st.stats.neuron_updates += (h + o) as u64;
                for j in 0..o {
                    st.out_spikes[j] = evolve(
                        &mut st.i_syn_out[j],
                        &mut st.v_mem_out[j],
                        self.spec.dash_syn_out[j],
                        self.spec.dash_mem_out[j],
                        self.spec.threshold_out[j],
                        MAX_OUT_SPIKES,
                    );
                }
            }
            Run::EventDriven => {
                // neurons with a state left from the last step are in the lists already; those
                // back at rest leave them (compacted in place)
                let XyloState { i_syn, v_mem, spikes, active, active_list, stats, .. } = st;
                stats.neuron_updates += active_list.len() as u64;
                let mut kept = 0;
                for k in 0..active_list.len() {
                    let j = active_list[k] as usize;
                    let (dash_syn, dash_mem, th) =
                        (self.spec.dash_syn[j], self.spec.dash_mem[j], self.spec.threshold[j]);
                    let n = evolve(&mut i_syn[j], &mut v_mem[j], dash_syn, dash_mem, th, MAX_SPIKES);
                    spikes[j] = n;
                    if n > 0 {
                        fired.push(j as u32);
                    }
                    if i_syn[j] != 0 || v_mem[j] != 0 {
                        active_list[kept] = j as u32;
                        kept += 1;
                    } else {
                        active[j] = false;
                    }
                }
                active_list.truncate(kept);
                // delivery order is ascending pre-synaptic neuron, as XyloSim's
                fired.sort_unstable();
                let XyloState { i_syn_out, v_mem_out, out_spikes, active_out, active_out_list, stats, .. } = st;
                stats.neuron_updates += active_out_list.len() as u64;
                let mut kept = 0;
                for k in 0..active_out_list.len() {
                    let j = active_out_list[k] as usize;
                    let (dash_syn, dash_mem, th) =
                        (self.spec.dash_syn_out[j], self.spec.dash_mem_out[j], self.spec.threshold_out[j]);
                    out_spikes[j] =
                        evolve(&mut i_syn_out[j], &mut v_mem_out[j], dash_syn, dash_mem, th, MAX_OUT_SPIKES);
                    if i_syn_out[j] != 0 || v_mem_out[j] != 0 {
                        active_out_list[kept] = j as u32;
                        kept += 1;
                    } else {
                        active_out[j] = false;
                    }
                }
                active_out_list.truncate(kept);
            }
        }
        st.stats.hidden_spikes += fired.iter().map(|&j| st.spikes[j as usize] as u64).sum::<u64>();
        st.stats.output_spikes += st.out_spikes.iter().map(|&n| n as u64).sum::<u64>();
        for j in 0..o {
            st.v_mem_out_max[j] = st.v_mem_out_max[j].max(st.v_mem_out[j]);
            st.out_spike_counts[j] += st.out_spikes[j] as u32;
        }
        st.fired = fired;
        st.step += 1;
        Ok(())
    }

    /// A stream's readout since rest, per output neuron: the highest membrane (at least zero) or
    /// the spike count, as the spec reads out.
    pub fn readout(&self, st: &XyloState) -> Vec<f32> {
        match self.spec.readout {
            XyloReadout::MaxMembrane => st.v_mem_out_max.iter().map(|&v| v as f32).collect(),
            XyloReadout::SpikeCount => st.out_spike_counts.iter().map(|&c| c as f32).collect(),
        }
    }

    /// Hidden neuron `j`'s spikes of the last step through `w_rec` and `w_out`.
    fn deliver_spikes_of(&self, st: &mut XyloState, j: usize) {
        let n = st.spikes[j].min(MAX_SPIKES) as u16;
        if n == 0 {
            return;
        }
        deliver(self.rows_rec.of(j), n, &mut st.i_syn, &mut st.stats.synops, &mut st.active, &mut st.active_list);
        deliver(
            self.rows_out.of(j),
            n,
            &mut st.i_syn_out,
            &mut st.stats.synops,
            &mut st.active_out,
            &mut st.active_out_list,
        );
    }

    /// A whole sample from rest: per step, its input channels and their events. Returns the
    /// readout per output neuron (the highest membrane over the steps, at least zero, or the
    /// spike count) and the stream's work.
    pub fn run_sample<'a>(
        &self,
        steps: impl IntoIterator<Item = (&'a [u32], &'a [u16])>,
        run: Run,
    ) -> Result<(Vec<f32>, XyloStats)> {
        let mut st = self.state();
        for (channels, events) in steps {
            self.step(&mut st, channels, events, run)?;
        }
        let readout = self.readout(&st);
        Ok((readout, st.stats))
    }
}

/// `n` spikes of one pre-synaptic neuron through its synapses (targets ascending, shifted
/// weights), XyloSim's order: each spike a saturating add.
fn deliver(
    (targets, weights): (&[u32], &[i64]),
    n: u16,
    i_syn: &mut [i16],
    synops: &mut u64,
    active: &mut [bool],
    list: &mut Vec<u32>,
) {
    for (&post, &w) in targets.iter().zip(weights) {
        let post = post as usize;
        // n saturating adds of one weight are one saturating add of n times it (safe_add is a
        // clamp for values in range, and a clamp of a monotone sum stays clamped)
        i_syn[post] = (i_syn[post] as i64 + n as i64 * w).clamp(i16::MIN as i64, i16::MAX as i64) as i16;
        *synops += n as u64;
        if !active[post] {
            active[post] = true;
            list.push(post as u32);
        }
    }
}

/// XyloSim v2's `XyloIAFNeuron::evolve` with one synapse: returns the spikes.
#[inline]
fn evolve(i_syn: &mut i16, v_mem: &mut i16, dash_syn: u8, dash_mem: u8, threshold: i16, max_spikes: u8) -> u8 {
    *i_syn -= decay(*i_syn, dash_syn);
    let dv = safe_add(-(decay(*v_mem, dash_mem) as i64), *i_syn as i64) as i16;
    *v_mem = safe_add(*v_mem as i64, dv as i64) as i16;
    // XyloSim's loop `while v >= threshold and n < max: n += 1; v -= threshold`, in closed form
    if *v_mem < threshold {
        return 0;
    }
    let n = ((*v_mem - threshold) / threshold + 1).min(max_spikes as i16);
    *v_mem -= n * threshold;
    n as u8
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::Layer;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn decay_moves_at_least_one_unit_and_shifts_negatives_down() {
        assert_eq!(decay(100, 4), 6);
        assert_eq!(decay(10, 4), 1); // 10 >> 4 = 0: one unit
        assert_eq!(decay(-10, 4), -1); // -10 >> 4 = -1 (arithmetic shift)
        assert_eq!(decay(-100, 4), -7); // floor(-6.25)
        assert_eq!(decay(0, 4), 0);
    }

    #[test]
    fn closed_forms_equal_xylosims_loops() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for _ in 0..20_000 {
            let x = rng.random_range(i16::MIN..=i16::MAX) as i64;
            let w = (rng.random_range(-128i64..=127)) << rng.random_range(0..=8u8);
            let n = rng.random_range(0..=31i64);
            let mut looped = x;
            for _ in 0..n {
                looped = safe_add(looped, w);
            }
            assert_eq!(looped, (x + n * w).clamp(i16::MIN as i64, i16::MAX as i64), "{x} {w} {n}");
            let th = rng.random_range(1..=i16::MAX);
            let (mut v, mut count) = (rng.random_range(i16::MIN..=i16::MAX), 0u8);
            let mut i = 0i16;
            let (mut v2, mut i2) = (v, i);
            let got = evolve(&mut i2, &mut v2, 15, 15, th, 31);
            // the loop on the same membrane after evolve's integration
            v = {
                i -= decay(i, 15);
                let dv = safe_add(-(decay(v, 15) as i64), i as i64) as i16;
                safe_add(v as i64, dv as i64) as i16
            };
            while v >= th && count < 31 {
                count += 1;
                v -= th;
            }
            assert_eq!((got, v2), (count, v));
        }
    }

    #[test]
    fn saturating_add_as_xylosim() {
        assert_eq!(safe_add(32_000, 1_000), 32_767);
        assert_eq!(safe_add(-32_000, -1_000), -32_768);
        assert_eq!(safe_add(100, -50), 50);
        assert_eq!(safe_add(32_767, 0), 32_767);
    }

    /// A hand-computed neuron: dash_syn 1, dash_mem 2, threshold 10, one input of weight 16 at
    /// step 0. i: 16 - 8 = 8; v: 0 + 8 = 8. Step 1: i = 8 - 4 = 4; v = 8 - 2 + 4 = 10 >= 10:
    /// a spike, v = 0. Step 2: i = 2, v = 2. Step 3: i = 1, v = 2 - 1 + 1 = 2.
    #[test]
    fn hand_computed_trajectory() {
        let spec = XyloSpec {
            n_in: 1,
            n_hidden: 1,
            n_out: 1,
            weights_in: vec![16],
            weights_rec: vec![0],
            weights_out: vec![1],
            weight_shift_in: 0,
            weight_shift_rec: 0,
            weight_shift_out: 0,
            dash_mem: vec![2],
            dash_syn: vec![1],
            dash_mem_out: vec![1],
            dash_syn_out: vec![1],
            threshold: vec![10],
            threshold_out: vec![i16::MAX],
            readout: XyloReadout::MaxMembrane,
            hidden_layers: vec![(0, 1)],
        };
        let spec = spec.compile().unwrap();
        for run in [Run::Stepped, Run::EventDriven] {
            let mut st = spec.state();
            let mut seen = Vec::new();
            for k in 0..4 {
                let (c, n): (&[u32], &[u16]) = if k == 0 { (&[0], &[1]) } else { (&[], &[]) };
                spec.step(&mut st, c, n, run).unwrap();
                seen.push((st.i_syn[0], st.v_mem[0], st.spikes[0], st.i_syn_out[0]));
            }
            // the output gets the spike of step 1 at step 2: i_out = 1 - decay(1, 1) = 0
            assert_eq!(seen, vec![(8, 8, 0, 0), (4, 0, 1, 0), (2, 2, 0, 0), (1, 2, 0, 0)], "{run:?}");
        }
    }

    fn random_net(seed: u64, n_in: usize, hidden: &[usize], n_out: usize, recurrent: bool) -> Network {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut layers = Vec::new();
        let mut prev = n_in;
        for &n in hidden {
            let weight = (0..n * prev).map(|_| rng.random_range(-1.5f32..1.5)).collect();
            let rec = recurrent.then(|| (0..n * n).map(|_| rng.random_range(-0.4f32..0.4)).collect());
            layers.push(Layer {
                op: Op::Dense { n_in: prev, n_out: n, weight, bias: None },
                neurons: Some(NeuronParams::cuba_lif(0.9, 0.95)),
                recurrent: rec,
                recurrent_bias: None,
            });
            prev = n;
        }
        let weight = (0..n_out * prev).map(|_| rng.random_range(-1.0f32..1.0)).collect();
        layers.push(Layer {
            op: Op::Dense { n_in: prev, n_out, weight, bias: None },
            neurons: Some(NeuronParams::leaky_integrator(0.9)),
            recurrent: None,
            recurrent_bias: None,
        });
        Network::new(vec![n_in], layers).unwrap()
    }

    fn random_input(seed: u64, steps: usize, n_in: usize) -> Vec<(Vec<u32>, Vec<u16>)> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..steps)
            .map(|_| {
                let c: Vec<u32> = (0..n_in as u32).filter(|_| rng.random_bool(0.3)).collect();
                let n = c.iter().map(|_| rng.random_range(1u16..20)).collect();
                (c, n)
            })
            .collect()
    }

    #[test]
    fn event_driven_is_stepped_bit_for_bit() {
        for seed in 0..6u64 {
            let net = random_net(seed, 8, if seed % 2 == 0 { &[24] } else { &[16, 12] }, 4, seed % 3 == 0);
            for q in [Quantisation::Global, Quantisation::Channel] {
                let spec = map(&net, q).unwrap().spec.compile().unwrap();
                let input = random_input(seed + 100, 60, 8);
                let (mut a, mut b) = (spec.state(), spec.state());
                let mut spikes = 0;
                for x in &input {
                    spec.step(&mut a, &x.0, &x.1, Run::Stepped).unwrap();
                    spec.step(&mut b, &x.0, &x.1, Run::EventDriven).unwrap();
                    assert_eq!((&a.i_syn, &a.v_mem, &a.spikes), (&b.i_syn, &b.v_mem, &b.spikes));
                    assert_eq!(
                        (&a.i_syn_out, &a.v_mem_out, &a.out_spikes),
                        (&b.i_syn_out, &b.v_mem_out, &b.out_spikes)
                    );
                    spikes += a.spikes.iter().map(|&n| n as u32).sum::<u32>();
                }
                assert!(spikes > 0, "seed {seed}: the test needs hidden spikes");
                assert_eq!(a.stats.synops, b.stats.synops);
                assert!(b.stats.neuron_updates < a.stats.neuron_updates);
            }
        }
    }

    #[test]
    fn mapping_rounds_decays_scales_and_shifts() {
        let net = random_net(3, 4, &[8], 2, false);
        let m = map(&net, Quantisation::Global).unwrap();
        // beta 0.95: tau = 19.5 steps -> log2 4.29 -> dash 4; alpha 0.9: 9.5 steps -> 3.25 -> 3
        assert_eq!(m.spec.dash_mem[0], 4);
        assert_eq!(m.spec.dash_syn[0], 3);
        assert_eq!(m.spec.dash_syn_out[0], 1);
        // the largest input weight takes 127
        assert_eq!(m.spec.weights_in.iter().map(|w| (*w as i32).abs()).max(), Some(127));
        // threshold 1 at 127 / max|w| units, shifted to at most 2^9
        let t = m.spec.threshold[0] as i32;
        let ceiling = 1i32 << THRESHOLD_BITS;
        assert!(t <= ceiling && t > ceiling / 2, "{t}");
        assert_eq!(m.spec.threshold_out[0], i16::MAX);
        assert!(m.approximations.contains(&Approximation::ResetBySubtraction { layer: 0 }));
        assert!(m.approximations.contains(&Approximation::OneStepDelay { layer: 1 }));
    }

    #[test]
    fn a_threshold_beyond_sixteen_bits_lowers_its_scale_as_rockpool() {
        // weights of 1e-4 take 127 at a scale of 1.27e6: threshold 1 would be 1.27e6 units
        let mut net = random_net(4, 4, &[8], 2, false);
        for l in &mut net.layers {
            if let Op::Dense { weight, .. } = &mut l.op {
                weight.iter_mut().for_each(|w| *w *= 1e-4);
            }
        }
        for q in [Quantisation::Global, Quantisation::Channel] {
            let spec = map(&net, q).unwrap().spec;
            assert!(spec.threshold.iter().all(|&t| t == i16::MAX), "{q:?}");
            assert!(spec.weights_in.iter().all(|&w| w.abs() < 16), "{q:?}");
            assert_eq!(spec.weight_shift_in, 0);
        }
    }

    #[test]
    fn networks_xylo_cannot_hold_say_why() {
        let mut net = random_net(1, 4, &[8], 2, false);
        net.layers[0].neurons = Some(NeuronParams::integrate_and_fire());
        let e = map(&net, Quantisation::Global).unwrap_err().to_string();
        assert!(e.contains("Xylo") && e.contains("layer 0") && e.contains("IF"), "{e}");
        let mut net = random_net(1, 4, &[8], 2, false);
        if let Op::Dense { bias, .. } = &mut net.layers[1].op {
            *bias = Some(vec![0.1, 0.1]);
        }
        let e = map(&net, Quantisation::Global).unwrap_err().to_string();
        assert!(e.contains("layer 1") && e.contains("bias"), "{e}");
        // beyond the chip's sizes: 24 inputs, 9 outputs
        let e = map(&random_net(1, 24, &[8], 2, false), Quantisation::Global).unwrap_err().to_string();
        assert!(e.contains("at most 16 input channels, the network 24"), "{e}");
        let e = map(&random_net(1, 4, &[8], 9, false), Quantisation::Channel).unwrap_err().to_string();
        assert!(e.contains("at most 8 output neurons"), "{e}");
    }

    #[test]
    fn input_events_are_capped_at_fifteen() {
        let net = random_net(2, 2, &[4], 2, false);
        let spec = map(&net, Quantisation::Global).unwrap().spec.compile().unwrap();
        let (mut a, mut b) = (spec.state(), spec.state());
        spec.step(&mut a, &[0], &[15], Run::Stepped).unwrap();
        spec.step(&mut b, &[0], &[40], Run::Stepped).unwrap();
        assert_eq!(a, b);
        assert!(spec.step(&mut a, &[1, 0], &[1, 1], Run::Stepped).is_err());
    }
}
