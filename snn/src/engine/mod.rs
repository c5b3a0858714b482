//! The event-driven engine: input events are handed in one at a time, in time order; each
//! reaches only the synapses it fans out to; membranes decay lazily, caught up only when a neuron
//! is next touched; spikes are events too. Many streams run at once, each with its own
//! [`EngineState`].
//!
//! Two modes:
//! - [`Mode::Stepped`] evaluates thresholds at `dt` boundaries and reproduces the time-stepped
//!   network ([`crate::network::forward_dense`]) spike for spike: inputs of one step are summed
//!   per input, propagated in ascending order, and each neuron's update is the same floating-point
//!   expression in the same order as the dense pass.
//! - [`Mode::Async`] fires a neuron the moment its membrane crosses threshold, with the exact
//!   exponential decay between events (LIF and IF layers; CubaLIF needs stepped mode).
//!
//! The engine by concern: this module holds the API ([`Engine`], [`EngineState`]); `compile`
//! lays each layer out for fan-out; `fanout` holds the fan-out maps and how inputs reach them;
//! `kernels` the stepped neuron updates; `simd` the SSE lanes of the convolution update.

mod compile;
mod fanout;
mod kernels;
mod simd;

use crate::error::{Error, Result};
use crate::network::Network;
use compile::{Compiled, Fan, compile, decay};
pub use compile::{conv_positions, pool_targets};
use fanout::{BitSet, Buckets, Marks, conv_inputs, fan_in, fan_in_buckets, fan_in_spikes, fan_out};
use kernels::evaluate;
#[cfg(target_arch = "x86_64")]
pub use simd::avx2;
pub use simd::{PACKED_LANES, PackedLanes};

/// The engine's buffers read and written a vector register at a time (membranes, accumulators,
/// weights, marks), on cache-line boundaries: a position's 8 or 16 lanes (32 or 64 bytes) and a
/// weight block then never straddle two lines, which the allocator's 16-byte alignment left to
/// chance (on the peer network, the first layer's membranes and the second's weights began 48
/// bytes into a line, so every other access to them straddled two; about 2% of the engine's
/// time, docs/engine.md, "the 2026-12-04 16:43Z session").
type Lines<T> = aligned_vec::AVec<T, aligned_vec::ConstAlign<64>>;

/// `n` copies of `value` on cache-line boundaries.
fn lines<T: Clone>(value: T, n: usize) -> Lines<T> {
    aligned_vec::avec![[64]| value; n]
}

/// `values` copied onto cache-line boundaries.
fn lines_from(values: &[f32]) -> Lines<f32> {
    Lines::from_slice(64, values)
}

/// When thresholds are evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Mode {
    Stepped,
    Async,
}

/// Work done, per stream.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct Stats {
    pub input_events: u64,
    /// Synaptic operations: one weight added to one target.
    pub synops: u64,
    /// Spikes per layer with neurons.
    pub spikes: Vec<u64>,
    /// Neuron updates (lazy catch-up steps included).
    pub neuron_updates: u64,
}

/// A compiled network, shared by all streams.
#[derive(Debug, Clone)]
pub struct Engine {
    layers: Vec<Compiled>,
    n_inputs: usize,
    dt_us: i64,
    mode: Mode,
}

#[derive(Debug, Clone)]
struct LayerState {
    v: Lines<f32>,
    i: Vec<f32>,
    /// Last step (stepped) or microsecond (async) each neuron was brought up to.
    last: Vec<i64>,
    acc: Lines<f32>,
    rec: Vec<f32>,
    /// Stepped: accumulator slots touched this step (conv: positions; others: neurons).
    touched: BitSet,
    /// Stepped convolutions of 8 or 16 channels: the positions their fan-ins reached this step,
    /// folded into `touched` when the step is evaluated.
    marks: Marks,
    /// Neurons to evaluate next step even without input.
    carry: BitSet,
    rec_pending: bool,
    /// This step's spikes (or, for identity layers, outputs that carry a value in `values`).
    spikes: Vec<u32>,
    values: Vec<f32>,
    /// Leaky-integrator readouts: `max(0, highest membrane so far)` per neuron.
    v_max: Vec<f32>,
    /// The previous step's spikes, for the recurrent input.
    prev: Vec<u32>,
    /// Scratch: the slots to evaluate this step.
    order: Vec<u32>,
    /// Scratch (convolutions): this step's spikes (or values) per output channel.
    by_channel: Buckets,
}

/// One stream's state: membranes, pending inputs, output spikes and counters.
///
/// Aligned to 128 bytes (two cache lines, as adjacent-line prefetchers pair them), so that the
/// states of streams run on different cores, held side by side (in a `Vec`), never share a line:
/// each step writes a stream's step and counters, and a shared line would bounce between cores.
#[derive(Debug, Clone)]
#[repr(align(128))]
pub struct EngineState {
    t0_us: i64,
    step: i64,
    /// Stepped: absolute step of this stream's step 0; neurons last updated before it are fresh
    /// (at rest), which makes [`Engine::reset`] cost nothing per neuron.
    base: i64,
    inputs: Vec<f32>,
    input_set: BitSet,
    layers: Vec<LayerState>,
    started: bool,
    pub stats: Stats,
    /// Output spikes: (time in us, or step start for stepped mode; output index).
    pub output: Vec<(i64, u32)>,
}

impl EngineState {
    /// A leaky-integrator output layer's readout: per neuron, the highest membrane reached at a
    /// step boundary (stepped) or after an input (async), and at least 0. Empty when the output
    /// layer spikes.
    pub fn output_v_max(&self) -> &[f32] {
        self.layers.last().map_or(&[], |l| &l.v_max)
    }

    /// Spike counts of the output layer.
    pub fn output_counts(&self, n: usize) -> Vec<u32> {
        let mut c = vec![0; n];
        for &(_, i) in &self.output {
            c[i as usize] += 1;
        }
        c
    }
}

impl Engine {
    pub fn new(net: &Network, dt_us: i64, mode: Mode) -> Result<Engine> {
        net.validate()?;
        if dt_us <= 0 {
            return Err(Error::network(format!("dt must be positive, got {dt_us} us")));
        }
        let mut layers = net.layers.iter().map(|l| compile(l, dt_us, mode)).collect::<Result<Vec<_>>>()?;
        if mode == Mode::Stepped {
            for k in 1..layers.len() {
                let (c, next) = (&layers[k - 1], &layers[k]);
                let by_bucket = c.neurons.is_some()
                    && c.rec_t.is_none()
                    && matches!(c.fan, Fan::Conv { .. })
                    && matches!(next.fan, Fan::Conv { out_c: 8 | 16, .. });
                layers[k - 1].spikes_in_buckets = by_bucket;
            }
        }
        Ok(Engine { layers, n_inputs: net.n_inputs(), dt_us, mode })
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    pub fn n_outputs(&self) -> usize {
        self.layers.last().map_or(0, |l| l.n_out)
    }

    /// A fresh stream whose step 0 starts at `t0_us`.
    pub fn state(&self, t0_us: i64) -> EngineState {
        let layers = self
            .layers
            .iter()
            .map(|l| {
                let slots = match &l.fan {
                    Fan::Conv { out_hw, .. } => out_hw[0] * out_hw[1],
                    _ => l.n_out,
                };
                let stepped = self.mode == Mode::Stepped;
                let (last_len, channels) = match &l.fan {
                    Fan::Conv { out_hw, out_c, .. } if stepped => (out_hw[0] * out_hw[1], *out_c),
                    _ => (l.n_out, 0),
                };
                LayerState {
                    v: lines(0.0, l.n_out),
                    i: vec![0.0; l.n_out],
                    last: vec![if stepped { -1 } else { t0_us }; last_len],
                    by_channel: Buckets::new(channels, if channels > 0 { slots } else { 0 }, l.neurons.is_none()),
                    acc: lines(0.0, l.n_out),
                    rec: vec![0.0; if l.rec_t.is_some() { l.n_out } else { 0 }],
                    touched: BitSet::new(slots),
                    marks: Marks::new(if channels > 0 { slots } else { 0 }),
                    carry: BitSet::new(if channels > 0 { slots } else { l.n_out }),
                    rec_pending: false,
                    spikes: Vec::new(),
                    values: Vec::new(),
                    v_max: vec![0.0; if l.track_max { l.n_out } else { 0 }],
                    prev: Vec::new(),
                    order: Vec::new(),
                }
            })
            .collect();
        EngineState {
            t0_us,
            step: 0,
            base: 0,
            inputs: vec![0.0; self.n_inputs],
            input_set: BitSet::new(self.n_inputs),
            layers,
            started: false,
            stats: Stats { spikes: vec![0; self.layers.len()], ..Stats::default() },
            output: Vec::new(),
        }
    }

    /// Makes `st` a fresh stream starting at `t0_us`, reusing its memory.
    pub fn reset(&self, st: &mut EngineState, t0_us: i64) {
        let values = &mut st.inputs;
        st.input_set.drain(|i| values[i] = 0.0);
        for (c, s) in self.layers.iter().zip(st.layers.iter_mut()) {
            s.touched.clear();
            s.marks.clear();
            s.carry.clear();
            s.acc.iter_mut().for_each(|a| *a = 0.0);
            s.rec_pending = false;
            s.prev.clear();
            s.spikes.clear();
            s.by_channel.clear();
            s.values.clear();
            s.v_max.iter_mut().for_each(|v| *v = 0.0);
            if self.mode == Mode::Async {
                s.v.iter_mut().for_each(|v| *v = 0.0);
                s.i.iter_mut().for_each(|v| *v = 0.0);
                s.last.iter_mut().for_each(|l| *l = t0_us);
            }
            let _ = c;
        }
        st.base += st.step + 2;
        st.t0_us = t0_us;
        st.step = 0;
        st.started = false;
        st.output.clear();
        st.stats = Stats { spikes: vec![0; self.layers.len()], ..Stats::default() };
    }

    /// Hands in one input event. Events must come in time order.
    #[inline]
    pub fn push(&self, st: &mut EngineState, t_us: i64, input: u32, value: f32) -> Result<()> {
        let i = input as usize;
        if i >= self.n_inputs {
            return Err(Error::input(format!("input {input} outside 0..{}", self.n_inputs)));
        }
        if t_us < st.t0_us {
            return Err(Error::input(format!("event at {t_us} us before the stream's start {} us", st.t0_us)));
        }
        st.stats.input_events += 1;
        match self.mode {
            Mode::Stepped => {
                let step = (t_us - st.t0_us) / self.dt_us;
                if step < st.step {
                    return Err(Error::input(format!("event at {t_us} us goes back to step {step} (now {})", st.step)));
                }
                if step > st.step || !st.started {
                    self.advance_to(st, step);
                }
                st.inputs[i] += value;
                st.input_set.insert(i);
                Ok(())
            }
            Mode::Async => {
                if st.started && t_us < st.step {
                    return Err(Error::input(format!("event at {t_us} us goes backwards (last {} us)", st.step)));
                }
                st.started = true;
                st.step = t_us;
                self.async_event(st, 0, i, value, t_us);
                Ok(())
            }
        }
    }

    /// Runs a whole spike train (its steps must be this engine's `dt`) through `st`, from the
    /// train's start, and completes its last step.
    pub fn run_train(&self, st: &mut EngineState, train: &encoders::spike_train::SpikeTrain) -> Result<()> {
        if train.dt_us != self.dt_us || train.n_inputs != self.n_inputs {
            return Err(Error::input(format!(
                "a spike train of {} inputs at dt {} us does not fit a network of {} inputs at dt {} us",
                train.n_inputs, train.dt_us, self.n_inputs, self.dt_us
            )));
        }
        self.reset(st, train.t_start_us);
        for k in 0..train.n_steps() {
            let t = train.t_start_us + k as i64 * self.dt_us;
            let (inputs, counts) = train.step(k);
            for (&i, &c) in inputs.iter().zip(counts) {
                self.push(st, t, i, c as f32)?;
            }
        }
        self.finish(st, train.t_start_us + train.n_steps() as i64 * self.dt_us);
        Ok(())
    }

    /// Completes every step up to (not including) the one holding `t_end_us`.
    pub fn finish(&self, st: &mut EngineState, t_end_us: i64) {
        if self.mode == Mode::Stepped {
            let end = (t_end_us - st.t0_us + self.dt_us - 1) / self.dt_us;
            self.advance_to(st, end.max(st.step + 1));
        }
    }

    /// Runs steps from the current one until `step` (exclusive), then makes `step` current.
    fn advance_to(&self, st: &mut EngineState, step: i64) {
        if !st.started {
            st.started = true;
            // Layers that change without input (bias, resting level above threshold) live from
            // the stream's step 0; otherwise the empty steps before the first input are skipped.
            st.step = if self.layers.iter().any(|c| c.every_step) { 0 } else { step };
        }
        while st.step < step {
            self.run_step(st);
            st.step += 1;
            // Steps with nothing to do are skipped: nothing decays that is not caught up lazily.
            if !self.needs_step(st) && st.step < step {
                st.step = step;
            }
        }
    }

    fn needs_step(&self, st: &EngineState) -> bool {
        st.input_set.any
            || self.layers.iter().zip(&st.layers).any(|(c, s)| c.every_step || s.carry.any || s.rec_pending)
    }

    /// One time step through every layer.
    fn run_step(&self, st: &mut EngineState) {
        #[cfg(target_arch = "x86_64")]
        if simd::avx2() {
            // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
            return unsafe { self.run_step_avx2(st) };
        }
        self.run_step_with(st)
    }

    /// [`Engine::run_step`] compiled for AVX2 (the same operations: nothing is fused or reordered).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    fn run_step_avx2(&self, st: &mut EngineState) {
        self.run_step_with(st)
    }

    #[inline(always)]
    fn run_step_with(&self, st: &mut EngineState) {
        let t = st.base + st.step;
        let base = st.base;
        let mut inputs = std::mem::take(&mut st.input_set);
        let (values, layers, stats) = (&mut st.inputs, &mut st.layers, &mut st.stats);
        // Inputs, in ascending order, into layer 0.
        {
            let (c0, s0) = (&self.layers[0], &mut layers[0]);
            stats.synops += match &c0.fan {
                Fan::Conv { out_c: 8, wt, map, .. } => conv_inputs::<8>(s0, wt, map, &mut inputs, values),
                Fan::Conv { out_c: 16, wt, map, .. } => conv_inputs::<16>(s0, wt, map, &mut inputs, values),
                _ => {
                    let mut n = 0;
                    inputs.drain(|i| n += fan_in(c0, s0, i, std::mem::take(&mut values[i])));
                    n
                }
            };
        }
        st.input_set = inputs;
        for k in 0..self.layers.len() {
            let (done, rest) = layers.split_at_mut(k + 1);
            let s = &mut done[k];
            let c = &self.layers[k];
            s.spikes.clear();
            s.values.clear();
            evaluate(c, s, t, base, stats);
            if c.neurons.is_some() {
                stats.spikes[k] += if c.spikes_in_buckets { s.by_channel.count() } else { s.spikes.len() } as u64;
            }
            if let Some(next) = rest.first_mut() {
                let cn = &self.layers[k + 1];
                if c.spikes_in_buckets {
                    stats.synops += fan_in_buckets(cn, next, &s.by_channel);
                } else if c.neurons.is_some() {
                    stats.synops += fan_in_spikes(cn, next, &s.spikes);
                } else {
                    // Identity layer: its values pass on.
                    for (&j, &x) in s.spikes.iter().zip(&s.values) {
                        stats.synops += fan_in(cn, next, j as usize, x);
                    }
                }
            }
        }
        if let Some(last) = st.layers.last()
            && self.layers.last().is_some_and(|c| c.neurons.is_some())
        {
            let t_us = st.t0_us + st.step * self.dt_us;
            st.output.extend(last.spikes.iter().map(|&j| (t_us, j)));
        }
    }

    /// Async: an event of value `x` at input `i` of layer `k` at time `t_us`, followed depth-first.
    fn async_event(&self, st: &mut EngineState, k: usize, i: usize, x: f32, t_us: i64) {
        let c = &self.layers[k];
        let s = &mut st.layers[k];
        let mut fired: Vec<(usize, f32)> = Vec::new();
        let mut synops = 0u64;
        let mut updates = 0u64;
        fan_out(&c.fan, i, |o, w| {
            synops += 1;
            match &c.neurons {
                None => fired.push((o, x * w)),
                Some(p) => {
                    let dt = t_us - s.last[o];
                    if dt > 0 {
                        s.v[o] = decay(c, p, s.v[o], dt);
                        s.last[o] = t_us;
                        updates += 1;
                    }
                    s.v[o] += x * w;
                    if let Some(m) = s.v_max.get_mut(o) {
                        *m = m.max(s.v[o]);
                    }
                    if s.v[o] > p.threshold() {
                        s.v[o] = match p.reset {
                            crate::neuron::Reset::Zero => p.v_reset,
                            crate::neuron::Reset::Subtract => s.v[o] - p.v_th,
                        };
                        fired.push((o, 1.0));
                    }
                }
            }
        });
        st.stats.synops += synops;
        st.stats.neuron_updates += updates;
        if c.neurons.is_some() {
            st.stats.spikes[k] += fired.len() as u64;
        }
        if k + 1 == self.layers.len() {
            if c.neurons.is_some() {
                st.output.extend(fired.iter().map(|&(o, _)| (t_us, o as u32)));
            }
            return;
        }
        for (o, value) in fired {
            self.async_event(st, k + 1, o, value, t_us);
        }
    }
}
