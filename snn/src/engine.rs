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

use crate::error::{Error, Result};
use crate::network::{Layer, Network, Op, PoolKind};
use crate::neuron::{NeuronKind, NeuronParams};

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

/// A fixed-size set of indices, iterated in ascending order.
#[derive(Debug, Clone, Default)]
struct BitSet {
    words: Vec<u64>,
    any: bool,
}

impl BitSet {
    fn new(n: usize) -> Self {
        Self { words: vec![0; n.div_ceil(64)], any: false }
    }
    #[inline]
    fn insert(&mut self, i: usize) {
        self.words[i >> 6] |= 1 << (i & 63);
        self.any = true;
    }
    /// Calls `f` on every member in ascending order and empties the set.
    #[inline]
    fn drain(&mut self, mut f: impl FnMut(usize)) {
        if !self.any {
            return;
        }
        for (w, word) in self.words.iter_mut().enumerate() {
            let mut bits = std::mem::take(word);
            while bits != 0 {
                let b = bits.trailing_zeros() as usize;
                f(w * 64 + b);
                bits &= bits - 1;
            }
        }
        self.any = false;
    }
}

/// A convolution's outputs of one step sorted by channel: the positions (and, for identity layers,
/// values) of channel `ch` are at `ch * plane ..` in order of arrival. Fixed-size, so that adding
/// one is a store and an increment.
#[derive(Debug, Clone, Default)]
struct Buckets {
    plane: usize,
    len: Vec<u32>,
    pos: Vec<u32>,
    val: Vec<f32>,
}

impl Buckets {
    fn new(channels: usize, plane: usize, values: bool) -> Self {
        Self {
            plane,
            len: vec![0; channels],
            pos: vec![0; channels * plane],
            val: vec![0.0; if values { channels * plane } else { 0 }],
        }
    }
    /// A spike at `pos` of channel `ch`; each position comes at most once per channel and step.
    #[inline(always)]
    fn push(&mut self, ch: usize, pos: u32) {
        let k = ch * self.plane + self.len[ch] as usize;
        self.pos[k] = pos;
        self.len[ch] += 1;
    }
    /// Spikes at `pos` of the channels whose bits are set in `fired` (the first `N`), without a
    /// branch per spike: every channel's next slot gets `pos`, and only the fired ones advance.
    /// A position comes at most once per step, so a channel's next slot is always inside its
    /// plane: it is full only after the last position.
    #[inline(always)]
    fn push_mask<const N: usize>(&mut self, fired: u32, pos: u32) {
        let len: &mut [u32; N] = (&mut self.len[..N]).try_into().expect("N channels");
        for (ch, n) in len.iter_mut().enumerate() {
            self.pos[ch * self.plane + *n as usize] = pos;
            *n += (fired >> ch) & 1;
        }
    }
    #[inline(always)]
    fn push_value(&mut self, ch: usize, pos: u32, x: f32) {
        let k = ch * self.plane + self.len[ch] as usize;
        self.val[k] = x;
        self.push(ch, pos);
    }
    fn positions(&self, ch: usize) -> &[u32] {
        &self.pos[ch * self.plane..ch * self.plane + self.len[ch] as usize]
    }
    fn values(&self, ch: usize) -> &[f32] {
        &self.val[ch * self.plane..ch * self.plane + self.len[ch] as usize]
    }
    fn clear(&mut self) {
        self.len.iter_mut().for_each(|n| *n = 0);
    }
}

/// Where a convolution's inputs reach. The output positions depend on an input's pixel, not its
/// channel, so one list per pixel serves every channel (small enough to stay in cache): pixel
/// `p`'s targets are `targets[offsets[p]..offsets[p + 1]]`, each (output position, weight
/// offset within the input channel's block of `channel_stride` weights).
#[derive(Debug, Clone)]
struct ConvTargets {
    plane: usize,
    channel_stride: usize,
    offsets: Vec<u32>,
    targets: Vec<(u32, u32)>,
}

impl ConvTargets {
    /// Input `i`'s targets and the offset of its channel's weights.
    #[inline(always)]
    fn of(&self, i: usize) -> (&[(u32, u32)], usize) {
        let (c, p) = (i / self.plane, i % self.plane);
        (&self.targets[self.offsets[p] as usize..self.offsets[p + 1] as usize], c * self.channel_stride)
    }
}

/// A linear operation laid out for fan-out.
#[derive(Debug, Clone)]
enum Fan {
    /// Weights `[in][out]`.
    Dense {
        n_out: usize,
        wt: Vec<f32>,
    },
    /// Weights `[in_c][ky][kx][out_c]`; accumulators `[pos][out_c]`; `map`: the targets of each
    /// input.
    Conv {
        in_hw: [usize; 2],
        out_c: usize,
        out_hw: [usize; 2],
        kernel: [usize; 2],
        stride: [usize; 2],
        padding: [usize; 2],
        wt: Vec<f32>,
        map: ConvTargets,
    },
    Pool {
        weight: f32,
        in_hw: [usize; 2],
        out_hw: [usize; 2],
        kernel: [usize; 2],
        stride: [usize; 2],
    },
}

#[derive(Debug, Clone)]
struct Compiled {
    fan: Fan,
    n_out: usize,
    neurons: Option<NeuronParams>,
    bias: Option<Vec<f32>>,
    /// Recurrent weights `[in][out]`.
    rec_t: Option<Vec<f32>>,
    /// Recurrent bias, added from the stream's step 1 on.
    rec_bias: Option<Vec<f32>>,
    /// Every neuron is evaluated every step (bias, or a resting level above threshold).
    every_step: bool,
    /// A leaky-integrator readout: keep each neuron's highest membrane.
    track_max: bool,
    /// Async mode: per-microsecond decay factors.
    decay_table: Vec<f32>,
    ln_beta_per_us: f64,
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
    v: Vec<f32>,
    i: Vec<f32>,
    /// Last step (stepped) or microsecond (async) each neuron was brought up to.
    last: Vec<i64>,
    acc: Vec<f32>,
    rec: Vec<f32>,
    /// Stepped: accumulator slots touched this step (conv: positions; others: neurons).
    touched: BitSet,
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
#[derive(Debug, Clone)]
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
            return Err(Error::Network(format!("dt must be positive, got {dt_us} us")));
        }
        let layers = net.layers.iter().map(|l| compile(l, dt_us, mode)).collect::<Result<Vec<_>>>()?;
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
                    v: vec![0.0; l.n_out],
                    i: vec![0.0; l.n_out],
                    last: vec![if stepped { -1 } else { t0_us }; last_len],
                    by_channel: Buckets::new(channels, if channels > 0 { slots } else { 0 }, l.neurons.is_none()),
                    acc: vec![0.0; l.n_out],
                    rec: vec![0.0; if l.rec_t.is_some() { l.n_out } else { 0 }],
                    touched: BitSet::new(slots),
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
            s.touched.drain(|_| {});
            s.carry.drain(|_| {});
            s.acc.iter_mut().for_each(|a| *a = 0.0);
            s.rec_pending = false;
            s.prev.clear();
            s.spikes.clear();
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
            return Err(Error::Input(format!("input {input} outside 0..{}", self.n_inputs)));
        }
        if t_us < st.t0_us {
            return Err(Error::Input(format!("event at {t_us} us before the stream's start {} us", st.t0_us)));
        }
        st.stats.input_events += 1;
        match self.mode {
            Mode::Stepped => {
                let step = (t_us - st.t0_us) / self.dt_us;
                if step < st.step {
                    return Err(Error::Input(format!("event at {t_us} us goes back to step {step} (now {})", st.step)));
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
                    return Err(Error::Input(format!("event at {t_us} us goes backwards (last {} us)", st.step)));
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
            return Err(Error::Input(format!(
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
                stats.spikes[k] += s.spikes.len() as u64;
            }
            if let Some(next) = rest.first_mut() {
                let cn = &self.layers[k + 1];
                if c.neurons.is_some() {
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

/// Exact decay of a LIF membrane over `dt_us` towards its resting level.
#[inline]
fn decay(c: &Compiled, p: &NeuronParams, v: f32, dt_us: i64) -> f32 {
    let f = match c.decay_table.get(dt_us as usize) {
        Some(&f) => f,
        None => (c.ln_beta_per_us * dt_us as f64).exp() as f32,
    };
    p.v_leak + (v - p.v_leak) * f
}

fn compile(l: &Layer, dt_us: i64, mode: Mode) -> Result<Compiled> {
    let n_out = l.op.n_out();
    let fan = match &l.op {
        Op::Dense { n_in, n_out, weight, .. } => {
            let mut wt = vec![0.0; n_in * n_out];
            for o in 0..*n_out {
                for i in 0..*n_in {
                    wt[i * n_out + o] = weight[o * n_in + i];
                }
            }
            Fan::Dense { n_out: *n_out, wt }
        }
        Op::Conv2d { in_shape, out_channels, kernel, stride, padding, weight, .. } => {
            let [ic, h, w] = *in_shape;
            let (oc, kh, kw) = (*out_channels, kernel[0], kernel[1]);
            let mut wt = vec![0.0; ic * kh * kw * oc];
            for o in 0..oc {
                for c in 0..ic {
                    for y in 0..kh {
                        for x in 0..kw {
                            wt[((c * kh + y) * kw + x) * oc + o] = weight[((o * ic + c) * kh + y) * kw + x];
                        }
                    }
                }
            }
            let s = l.op.out_shape();
            let out_hw = [s[1], s[2]];
            let mut offsets = Vec::with_capacity(h * w + 1);
            let mut targets = Vec::new();
            offsets.push(0);
            for y in 0..h {
                for x in 0..w {
                    conv_positions(y, x, *kernel, *stride, *padding, out_hw, |ky, kx, pos| {
                        targets.push((pos as u32, ((ky * kw + kx) * oc) as u32));
                    });
                    offsets.push(targets.len() as u32);
                }
            }
            let map = ConvTargets { plane: h * w, channel_stride: kh * kw * oc, offsets, targets };
            Fan::Conv { in_hw: [h, w], out_c: oc, out_hw, kernel: *kernel, stride: *stride, padding: *padding, wt, map }
        }
        Op::Pool { kind, in_shape, kernel, stride } => {
            let s = l.op.out_shape();
            let weight = match kind {
                PoolKind::Sum => 1.0,
                PoolKind::Avg => 1.0 / (kernel[0] * kernel[1]) as f32,
            };
            Fan::Pool {
                weight,
                in_hw: [in_shape[1], in_shape[2]],
                out_hw: [s[1], s[2]],
                kernel: *kernel,
                stride: *stride,
            }
        }
    };
    let rec_t = l.recurrent.as_ref().map(|w| {
        let mut t = vec![0.0; n_out * n_out];
        for o in 0..n_out {
            for i in 0..n_out {
                t[i * n_out + o] = w[o * n_out + i];
            }
        }
        t
    });
    let p = l.neurons;
    let every_step = l.op.bias().is_some() || l.recurrent_bias.is_some() || p.is_some_and(|p| p.v_leak > p.threshold());
    let (mut decay_table, mut ln_beta_per_us) = (Vec::new(), 0.0);
    if mode == Mode::Async
        && let Some(p) = p
    {
        if p.kind == NeuronKind::CubaLif || l.recurrent.is_some() || l.op.bias().is_some() {
            return Err(Error::Network(
                "async mode runs LIF and IF layers without bias or recurrence; use stepped mode".into(),
            ));
        }
        ln_beta_per_us = if p.beta > 0.0 { (p.beta as f64).ln() / dt_us as f64 } else { f64::NEG_INFINITY };
        let len = if ln_beta_per_us < 0.0 { ((30.0 / -ln_beta_per_us) as usize).min(1 << 20) } else { 1 << 10 };
        decay_table = (0..len).map(|d| (ln_beta_per_us * d as f64).exp() as f32).collect();
    }
    Ok(Compiled {
        fan,
        n_out,
        neurons: p,
        bias: l.op.bias().map(<[f32]>::to_vec),
        rec_t,
        rec_bias: l.recurrent_bias.clone(),
        every_step,
        track_max: p.is_some_and(|p| p.kind == NeuronKind::Li),
        decay_table,
        ln_beta_per_us,
    })
}

/// Calls `f(out, w)` for every target of input `i` (async mode, canonical output indices).
#[inline]
fn fan_out(fan: &Fan, i: usize, mut f: impl FnMut(usize, f32)) {
    match fan {
        Fan::Dense { n_out, wt } => {
            for (o, &w) in wt[i * n_out..(i + 1) * n_out].iter().enumerate() {
                f(o, w);
            }
        }
        Fan::Conv { in_hw, out_c, out_hw, kernel, stride, padding, wt, .. } => {
            let plane = in_hw[0] * in_hw[1];
            let (c, y, x) = (i / plane, (i % plane) / in_hw[1], i % in_hw[1]);
            let opl = out_hw[0] * out_hw[1];
            conv_positions(y, x, *kernel, *stride, *padding, *out_hw, |ky, kx, pos| {
                let base = ((c * kernel[0] + ky) * kernel[1] + kx) * out_c;
                for (o, &w) in wt[base..base + out_c].iter().enumerate() {
                    f(o * opl + pos, w);
                }
            });
        }
        Fan::Pool { weight, in_hw, out_hw, kernel, stride } => {
            pool_targets(i, *in_hw, *out_hw, *kernel, *stride, |o| f(o, *weight));
        }
    }
}

/// Output positions `(ky, kx, oy * ow + ox)` that input pixel `(y, x)` reaches.
#[inline]
fn conv_positions(
    y: usize,
    x: usize,
    k: [usize; 2],
    s: [usize; 2],
    p: [usize; 2],
    out: [usize; 2],
    mut f: impl FnMut(usize, usize, usize),
) {
    let (ty, tx) = (y + p[0], x + p[1]);
    for ky in 0..k[0] {
        if ty < ky || (ty - ky) % s[0] != 0 {
            continue;
        }
        let oy = (ty - ky) / s[0];
        if oy >= out[0] {
            continue;
        }
        for kx in 0..k[1] {
            if tx < kx || (tx - kx) % s[1] != 0 {
                continue;
            }
            let ox = (tx - kx) / s[1];
            if ox < out[1] {
                f(ky, kx, oy * out[1] + ox);
            }
        }
    }
}

#[inline]
fn pool_targets(
    i: usize,
    in_hw: [usize; 2],
    out_hw: [usize; 2],
    k: [usize; 2],
    s: [usize; 2],
    mut f: impl FnMut(usize),
) {
    let plane = in_hw[0] * in_hw[1];
    let (c, y, x) = (i / plane, (i % plane) / in_hw[1], i % in_hw[1]);
    for oy in 0..out_hw[0] {
        if y < oy * s[0] || y >= oy * s[0] + k[0] {
            continue;
        }
        for ox in 0..out_hw[1] {
            if x >= ox * s[1] && x < ox * s[1] + k[1] {
                f((c * out_hw[0] + oy) * out_hw[1] + ox);
            }
        }
    }
}

/// Stepped: adds input `i` with value `x` into the layer's accumulators; returns synops.
#[inline]
fn fan_in(c: &Compiled, s: &mut LayerState, i: usize, x: f32) -> u64 {
    match &c.fan {
        Fan::Dense { n_out, wt } => {
            for (a, &w) in s.acc.iter_mut().zip(&wt[i * n_out..(i + 1) * n_out]) {
                *a += x * w;
            }
            s.touched.insert(0);
            *n_out as u64
        }
        Fan::Conv { out_c, wt, map, .. } => {
            let oc = *out_c;
            let (list, wc) = map.of(i);
            let wt = &wt[wc..];
            match oc {
                8 => conv_fan_in::<8>(&mut s.acc, &mut s.touched, wt, list, x),
                16 => conv_fan_in::<16>(&mut s.acc, &mut s.touched, wt, list, x),
                _ => {
                    for &(pos, w) in list {
                        let (pos, w) = (pos as usize, w as usize);
                        for (a, &w) in s.acc[pos * oc..(pos + 1) * oc].iter_mut().zip(&wt[w..w + oc]) {
                            *a += x * w;
                        }
                        s.touched.insert(pos);
                    }
                }
            }
            (list.len() * oc) as u64
        }
        Fan::Pool { weight, in_hw, out_hw, kernel, stride } => {
            let mut n = 0;
            let (acc, touched) = (&mut s.acc, &mut s.touched);
            pool_targets(i, *in_hw, *out_hw, *kernel, *stride, |o| {
                acc[o] += x * weight;
                touched.insert(o);
                n += 1;
            });
            n
        }
    }
}

/// Stepped: [`fan_in`] of spikes (value 1) at the inputs `spikes`, in order; returns synops.
/// Adding a weight itself is the same number as adding `1 * w`.
fn fan_in_spikes(c: &Compiled, s: &mut LayerState, spikes: &[u32]) -> u64 {
    if spikes.is_empty() {
        return 0;
    }
    match &c.fan {
        Fan::Dense { n_out, wt } => {
            let n = *n_out;
            for &i in spikes {
                let i = i as usize;
                for (a, &w) in s.acc.iter_mut().zip(&wt[i * n..(i + 1) * n]) {
                    *a += w;
                }
            }
            s.touched.insert(0);
            (spikes.len() * n) as u64
        }
        Fan::Conv { out_c: 8, wt, map, .. } => conv_spikes::<8>(s, wt, map, spikes),
        Fan::Conv { out_c: 16, wt, map, .. } => conv_spikes::<16>(s, wt, map, spikes),
        _ => spikes.iter().map(|&i| fan_in(c, s, i as usize, 1.0)).sum(),
    }
}

#[inline(never)]
fn conv_spikes<const N: usize>(s: &mut LayerState, wt: &[f32], map: &ConvTargets, spikes: &[u32]) -> u64 {
    let mut n = 0;
    for &i in spikes {
        let (list, wc) = map.of(i as usize);
        conv_fan_in::<N>(&mut s.acc, &mut s.touched, &wt[wc..], list, 1.0);
        n += list.len();
    }
    (n * N) as u64
}

/// The step's inputs (`set`, values in `values`, both emptied) into a convolution of `N`
/// channels, in ascending order; returns synops.
#[inline(never)]
fn conv_inputs<const N: usize>(
    s: &mut LayerState,
    wt: &[f32],
    map: &ConvTargets,
    set: &mut BitSet,
    values: &mut [f32],
) -> u64 {
    let mut n = 0;
    set.drain(|i| {
        let (list, wc) = map.of(i);
        conv_fan_in::<N>(&mut s.acc, &mut s.touched, &wt[wc..], list, std::mem::take(&mut values[i]));
        n += list.len();
    });
    (n * N) as u64
}

/// A convolution's fan-in with `N` output channels known at compile time, so that the adds
/// unroll into whole vector registers; `wt` starts at the input channel's weights. A spike (`x == 1`) adds the weight itself, which is the
/// same number as `1 * w`.
#[inline(always)]
fn conv_fan_in<const N: usize>(acc: &mut [f32], touched: &mut BitSet, wt: &[f32], list: &[(u32, u32)], x: f32) {
    for &(pos, w) in list {
        let (pos, w) = (pos as usize, w as usize);
        let a: &mut [f32; N] = (&mut acc[pos * N..pos * N + N]).try_into().expect("N channels");
        let w: &[f32; N] = (&wt[w..w + N]).try_into().expect("N weights");
        if x == 1.0 {
            for k in 0..N {
                a[k] += w[k];
            }
        } else {
            for k in 0..N {
                a[k] += x * w[k];
            }
        }
        touched.insert(pos);
    }
}

/// Stepped: updates the neurons that need it at step `t` (in ascending order) and collects the
/// spikes (or, for identity layers, the outputs that carry a value) in `s.spikes`.
///
/// Updating a neuron with zero input is exactly what the dense pass does to it, so the set
/// evaluated may be a superset of the neurons touched: whole positions of a convolution, every
/// neuron of a dense layer that received anything.
fn evaluate(c: &Compiled, s: &mut LayerState, t: i64, base: i64, stats: &mut Stats) {
    let n = c.n_out;
    // A recurrent bias makes the recurrent input present at every step after the first.
    let rec_bias = c.rec_bias.as_deref().filter(|_| t > base);
    let rec_on = s.rec_pending || rec_bias.is_some();
    let all = c.every_step || rec_on;
    // Recurrent input from the previous step's spikes, summed on its own.
    if rec_on && let Some(rt) = &c.rec_t {
        s.rec.iter_mut().for_each(|r| *r = 0.0);
        if s.rec_pending {
            for &j in &s.prev {
                for (r, &w) in s.rec.iter_mut().zip(&rt[j as usize * n..(j as usize + 1) * n]) {
                    *r += 1.0 * w;
                }
            }
        }
        if let Some(b) = rec_bias {
            for (r, b) in s.rec.iter_mut().zip(b) {
                *r += b;
            }
        }
    }
    let rec = if rec_on && c.rec_t.is_some() { Some(std::mem::take(&mut s.rec)) } else { None };
    let mut order = std::mem::take(&mut s.order);
    order.clear();
    match &c.fan {
        Fan::Conv { out_c, out_hw, .. } => {
            // State is laid out [position][channel] and a position is always updated whole, so
            // one `last` per position serves all its channels.
            let plane = out_hw[0] * out_hw[1];
            let oc = *out_c;
            schedule(s, all, plane, &mut order);
            let mut by_channel = std::mem::take(&mut s.by_channel);
            // LIF and IF without bias at 8 or 16 channels: one loop compiled for the width.
            let lanes = c.neurons.filter(|p| p.kind != NeuronKind::CubaLif && c.bias.is_none());
            let leak = lanes.is_some_and(|p| p.leak_term().to_bits() != 0);
            match (lanes, oc, leak) {
                (Some(p), 8, false) => lif_positions::<8, false>(&p, s, &order, t, base, &mut by_channel, stats),
                (Some(p), 8, true) => lif_positions::<8, true>(&p, s, &order, t, base, &mut by_channel, stats),
                (Some(p), 16, false) => lif_positions::<16, false>(&p, s, &order, t, base, &mut by_channel, stats),
                (Some(p), 16, true) => lif_positions::<16, true>(&p, s, &order, t, base, &mut by_channel, stats),
                _ => {
                    for &pos in &order {
                        update_position(c, s, pos as usize, oc, t, base, &mut by_channel, stats);
                    }
                }
            }
            // Canonical order: channel by channel, positions ascending.
            for ch in 0..oc {
                let offset = (ch * plane) as u32;
                s.spikes.extend(by_channel.positions(ch).iter().map(|&pos| offset + pos));
                if c.neurons.is_none() {
                    s.values.extend_from_slice(by_channel.values(ch));
                }
            }
            by_channel.clear();
            s.by_channel = by_channel;
        }
        Fan::Dense { .. } | Fan::Pool { .. } => {
            let dense = matches!(c.fan, Fan::Dense { .. });
            let everything = all || (dense && (s.touched.any || s.carry.any));
            schedule(s, everything, n, &mut order);
            for &o in &order {
                update(c, s, o as usize, o as usize, t, base, rec.as_deref(), stats);
            }
        }
    }
    s.order = order;
    if let Some(r) = rec {
        s.rec = r;
    }
    // Spikes of a convolution come channel by channel, already ascending.
    s.rec_pending = c.rec_t.is_some() && !s.spikes.is_empty();
    if s.rec_pending {
        s.prev.clear();
        let spikes = std::mem::take(&mut s.spikes);
        s.prev.extend_from_slice(&spikes);
        s.spikes = spikes;
    }
}

/// The slots to update this step, ascending: all `count` of them, or those touched or carried.
fn schedule(s: &mut LayerState, everything: bool, count: usize, order: &mut Vec<u32>) {
    if everything {
        s.touched.drain(|_| {});
        s.carry.drain(|_| {});
        order.extend(0..count as u32);
    } else {
        let touched = &mut s.touched;
        s.carry.drain(|p| touched.insert(p));
        touched.drain(|p| order.push(p as u32));
    }
}

/// A convolution's position `pos` at step `t`: all its channels, state at `pos * oc + ch`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn update_position(
    c: &Compiled,
    s: &mut LayerState,
    pos: usize,
    oc: usize,
    t: i64,
    base: i64,
    out: &mut Buckets,
    stats: &mut Stats,
) {
    let start = pos * oc;
    let (acc, v, i) = (&mut s.acc[start..start + oc], &mut s.v[start..start + oc], &mut s.i[start..start + oc]);
    let Some(p) = &c.neurons else {
        for ch in 0..oc {
            let mut u = std::mem::take(&mut acc[ch]);
            if let Some(b) = &c.bias {
                u += b[ch];
            }
            if u != 0.0 {
                out.push_value(ch, pos as u32, u);
            }
        }
        return;
    };
    let last = s.last[pos];
    let behind = if last < base {
        // fresh since the last reset: zero at the stream's start, then the steps since
        v.iter_mut().for_each(|x| *x = 0.0);
        i.iter_mut().for_each(|x| *x = 0.0);
        fresh_steps(p, t, base)
    } else {
        t - last - 1
    };
    stats.neuron_updates += ((behind.max(0) + 1) as usize * oc) as u64;
    s.last[pos] = t;
    let lif = p.kind != NeuronKind::CubaLif && c.bias.is_none();
    let carry = if lif && oc <= 64 {
        lif_position(p, v, acc, behind, pos as u32, out)
    } else {
        for _ in 0..behind.max(0) {
            for ch in 0..oc {
                p.step(&mut i[ch], &mut v[ch], 0.0);
            }
        }
        let cuba = p.kind == NeuronKind::CubaLif;
        let mut carry = false;
        for ch in 0..oc {
            let mut u = std::mem::take(&mut acc[ch]);
            if let Some(b) = &c.bias {
                u += b[ch];
            }
            if p.step(&mut i[ch], &mut v[ch], u) {
                out.push(ch, pos as u32);
            }
            let drive = if cuba { p.alpha * i[ch] } else { 0.0 };
            carry |= p.beta * v[ch] + p.leak_term() + drive > p.threshold() || (cuba && i[ch] != 0.0);
        }
        carry
    };
    if carry {
        s.carry.insert(pos);
    }
}

/// LIF and IF channels of one position, without branches in the arithmetic so that it
/// vectorises: the same floating-point expressions as [`NeuronParams::step`]. Returns whether the
/// position must be looked at next step even without input.
#[inline(always)]
fn lif_position(p: &NeuronParams, v: &mut [f32], acc: &mut [f32], behind: i64, pos: u32, out: &mut Buckets) -> bool {
    let (beta, leak, th, v_reset) = (p.beta, p.leak_term(), p.threshold(), p.v_reset);
    for _ in 0..behind.max(0) {
        for x in v.iter_mut() {
            *x = beta * *x + leak + 0.0;
        }
    }
    let mut fired = 0u64;
    let mut carry = false;
    for (ch, (x, a)) in v.iter_mut().zip(acc.iter_mut()).enumerate() {
        let u = std::mem::take(a);
        let vn = beta * *x + leak + u;
        let spike = vn > th;
        let after = match p.reset {
            crate::neuron::Reset::Zero => v_reset,
            crate::neuron::Reset::Subtract => vn - th,
        };
        *x = if spike { after } else { vn };
        fired |= (spike as u64) << ch;
        carry |= beta * *x + leak + 0.0 > th;
    }
    while fired != 0 {
        let ch = fired.trailing_zeros() as usize;
        out.push(ch, pos);
        fired &= fired - 1;
    }
    carry
}

/// The lanes of `x` above `th`, as bits (`N <= 32`): on x86-64, four lanes a compare.
#[inline(always)]
fn above<const N: usize>(x: &[f32; N], th: f32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if N.is_multiple_of(4) {
        use std::arch::x86_64::{_mm_cmpgt_ps, _mm_movemask_ps, _mm_set_ps, _mm_set1_ps};
        let mut m = 0u32;
        for (k, q) in x.chunks_exact(4).enumerate() {
            // SAFETY: SSE is part of the x86-64 baseline, so these are always available.
            let bits = unsafe { _mm_movemask_ps(_mm_cmpgt_ps(_mm_set_ps(q[3], q[2], q[1], q[0]), _mm_set1_ps(th))) };
            m |= (bits as u32) << (4 * k);
        }
        return m;
    }
    let mut m = 0u32;
    for (ch, &v) in x.iter().enumerate() {
        m |= ((v > th) as u32) << ch;
    }
    m
}

/// [`update_position`] for the positions in `order` of a LIF or IF convolution without bias and
/// with `N` channels: the neuron parameters stay in registers across positions.
#[inline(never)]
fn lif_positions<const N: usize, const LEAK: bool>(
    p: &NeuronParams,
    s: &mut LayerState,
    order: &[u32],
    t: i64,
    base: i64,
    out: &mut Buckets,
    stats: &mut Stats,
) {
    let LayerState { v, acc, last, carry, .. } = s;
    let mut steps = 0u64;
    for &pos in order {
        let k = pos as usize * N;
        let v: &mut [f32; N] = (&mut v[k..k + N]).try_into().expect("N channels");
        let acc: &mut [f32; N] = (&mut acc[k..k + N]).try_into().expect("N channels");
        let l = &mut last[pos as usize];
        let behind = if *l < base {
            // fresh since the last reset (a LIF's synaptic current stays unused)
            v.fill(0.0);
            fresh_steps(p, t, base)
        } else {
            t - *l - 1
        };
        *l = t;
        steps += (behind.max(0) + 1) as u64;
        if lif_lanes::<N, LEAK>(p, v, acc, behind, pos, out) {
            carry.insert(pos as usize);
        }
    }
    stats.neuron_updates += steps * N as u64;
}

/// [`lif_position`] with `N <= 32` channels known at compile time: the loops unroll into whole
/// vector registers, the spike and carry masks come from vector compares, and the spikes are
/// stored without a branch per spike (which mispredicts often: a position's spikes vary).
///
/// `LEAK = false` is for a resting level of exactly +0: the terms `+ leak + 0.0` are left out,
/// which changes nothing but the sign of a membrane at zero (`-0.0` against `+0.0`, equal in
/// every comparison), and shortens each step's chain of dependent operations by one add.
#[inline(always)]
fn lif_lanes<const N: usize, const LEAK: bool>(
    p: &NeuronParams,
    v: &mut [f32; N],
    acc: &mut [f32; N],
    behind: i64,
    pos: u32,
    out: &mut Buckets,
) -> bool {
    #[cfg(target_arch = "x86_64")]
    let (fired, carry) = if N.is_multiple_of(4) && N <= 16 {
        sse::lif_lanes::<N, LEAK>(p, v, acc, behind)
    } else {
        lif_masks::<N, LEAK>(p, v, acc, behind)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let (fired, carry) = lif_masks::<N, LEAK>(p, v, acc, behind);
    out.push_mask::<N>(fired, pos);
    carry
}

/// The update of [`lif_lanes`] in portable code: returns the lanes that fired (bits) and
/// whether any lane must be looked at next step.
#[inline(always)]
fn lif_masks<const N: usize, const LEAK: bool>(
    p: &NeuronParams,
    v: &mut [f32; N],
    acc: &mut [f32; N],
    behind: i64,
) -> (u32, bool) {
    let (beta, leak, th, v_reset) = (p.beta, p.leak_term(), p.threshold(), p.v_reset);
    let subtract = p.reset == crate::neuron::Reset::Subtract;
    for _ in 0..behind.max(0) {
        for x in v.iter_mut() {
            *x = if LEAK { beta * *x + leak + 0.0 } else { beta * *x };
        }
    }
    let mut vn = [0.0f32; N];
    for ch in 0..N {
        let u = std::mem::take(&mut acc[ch]);
        vn[ch] = if LEAK { beta * v[ch] + leak + u } else { beta * v[ch] + u };
    }
    let fired = above(&vn, th);
    let mut next = [0.0f32; N];
    for ch in 0..N {
        let after = if subtract { vn[ch] - th } else { v_reset };
        v[ch] = if vn[ch] > th { after } else { vn[ch] };
        next[ch] = if LEAK { beta * v[ch] + leak + 0.0 } else { beta * v[ch] };
    }
    (fired, above(&next, th) != 0)
}

/// The LIF lanes in SSE registers, four channels each (SSE is part of the x86-64 baseline).
#[cfg(target_arch = "x86_64")]
mod sse {
    use super::NeuronParams;
    use std::arch::x86_64::{
        __m128, _mm_add_ps, _mm_and_ps, _mm_andnot_ps, _mm_cmpgt_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_mul_ps,
        _mm_or_ps, _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps, _mm_sub_ps,
    };

    #[inline(always)]
    fn load(x: &[f32], q: usize) -> __m128 {
        let x: &[f32; 4] = x[4 * q..4 * q + 4].try_into().expect("four lanes");
        // SAFETY: `x` is four readable f32s; unaligned loads are allowed.
        unsafe { _mm_loadu_ps(x.as_ptr()) }
    }

    #[inline(always)]
    fn store(x: &mut [f32], q: usize, r: __m128) {
        let x: &mut [f32; 4] = (&mut x[4 * q..4 * q + 4]).try_into().expect("four lanes");
        // SAFETY: `x` is four writable f32s; unaligned stores are allowed.
        unsafe { _mm_storeu_ps(x.as_mut_ptr(), r) }
    }

    /// `beta * x + leak + u` (or `beta * x + u` without a resting level), as the scalar code.
    #[inline(always)]
    fn leak_step<const LEAK: bool>(beta: __m128, leak: __m128, x: __m128, u: __m128) -> __m128 {
        // SAFETY: SSE is part of the x86-64 baseline, so these are always available.
        unsafe {
            if LEAK { _mm_add_ps(_mm_add_ps(_mm_mul_ps(beta, x), leak), u) } else { _mm_add_ps(_mm_mul_ps(beta, x), u) }
        }
    }

    /// The same floating-point operations as [`super::lif_masks`], four lanes at a time; returns
    /// the lanes that fired (bits) and whether any lane must be looked at next step.
    #[inline(always)]
    pub(super) fn lif_lanes<const N: usize, const LEAK: bool>(
        p: &NeuronParams,
        v: &mut [f32; N],
        acc: &mut [f32; N],
        behind: i64,
    ) -> (u32, bool) {
        // SAFETY: SSE is part of the x86-64 baseline, so these are always available.
        let (fired, carry) = unsafe {
            let beta = _mm_set1_ps(p.beta);
            let leak = _mm_set1_ps(p.leak_term());
            let th = _mm_set1_ps(p.threshold());
            let zero = _mm_setzero_ps();
            let subtract = p.reset == crate::neuron::Reset::Subtract;
            let after_zero = _mm_set1_ps(p.v_reset);
            let mut x = [zero; 4];
            for (q, r) in x.iter_mut().enumerate().take(N / 4) {
                *r = load(v, q);
            }
            for _ in 0..behind.max(0) {
                for r in x.iter_mut().take(N / 4) {
                    *r = if LEAK { leak_step::<true>(beta, leak, *r, zero) } else { _mm_mul_ps(beta, *r) };
                }
            }
            let (mut fired, mut carry) = (0u32, 0i32);
            for (q, &xq) in x.iter().enumerate().take(N / 4) {
                let u = load(acc, q);
                store(acc, q, zero);
                let vn = leak_step::<LEAK>(beta, leak, xq, u);
                let m = _mm_cmpgt_ps(vn, th);
                let after = if subtract { _mm_sub_ps(vn, th) } else { after_zero };
                let nv = _mm_or_ps(_mm_and_ps(m, after), _mm_andnot_ps(m, vn));
                store(v, q, nv);
                fired |= (_mm_movemask_ps(m) as u32) << (4 * q);
                let next = if LEAK { leak_step::<true>(beta, leak, nv, zero) } else { _mm_mul_ps(beta, nv) };
                carry |= _mm_movemask_ps(_mm_cmpgt_ps(next, th));
            }
            (fired, carry)
        };
        (fired, carry != 0)
    }
}

/// The steps a neuron untouched since its stream's start (step `base`, at zero) must catch up
/// before step `t`: none when zero is its resting level (nothing changes), else every one, as
/// the membrane drifts towards a resting level that is not zero.
#[inline]
fn fresh_steps(p: &NeuronParams, t: i64, base: i64) -> i64 {
    if p.leak_term() == 0.0 { 0 } else { t - base }
}

/// One neuron's update at step `t`: neuron `o` (canonical), accumulator slot `k`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn update(
    c: &Compiled,
    s: &mut LayerState,
    o: usize,
    k: usize,
    t: i64,
    base: i64,
    rec: Option<&[f32]>,
    stats: &mut Stats,
) {
    let mut u = std::mem::take(&mut s.acc[k]);
    if let Some(b) = &c.bias {
        u += b[bias_index(&c.fan, o)];
    }
    let Some(p) = &c.neurons else {
        if u != 0.0 {
            s.spikes.push(o as u32);
            s.values.push(u);
        }
        return;
    };
    if let Some(r) = rec {
        u += r[o];
    }
    // Catch up the steps without input: the same update with zero input, which cannot fire
    // (a neuron that could is carried to the next step).
    let behind = if s.last[o] < base {
        s.v[o] = 0.0;
        s.i[o] = 0.0;
        fresh_steps(p, t, base)
    } else {
        t - s.last[o] - 1
    };
    if behind > 0 {
        for _ in 0..behind {
            p.step(&mut s.i[o], &mut s.v[o], 0.0);
        }
        stats.neuron_updates += behind as u64;
    }
    stats.neuron_updates += 1;
    s.last[o] = t;
    if p.step(&mut s.i[o], &mut s.v[o], u) {
        s.spikes.push(o as u32);
    }
    if c.track_max {
        s.v_max[o] = s.v_max[o].max(s.v[o]);
    }
    // Could this neuron fire next step without input? Then look at it again.
    let cuba = p.kind == NeuronKind::CubaLif;
    let drive = if cuba { p.alpha * s.i[o] } else { 0.0 };
    if p.beta * s.v[o] + p.leak_term() + drive > p.threshold() || (cuba && s.i[o] != 0.0) {
        s.carry.insert(o);
    }
}

fn bias_index(fan: &Fan, o: usize) -> usize {
    match fan {
        Fan::Conv { out_hw, .. } => o / (out_hw[0] * out_hw[1]),
        _ => o,
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::neuron::Reset;
    use rand::{Rng, SeedableRng};

    /// The SSE lanes give the portable code's numbers bit for bit, spikes and carry included.
    fn same_as_portable<const N: usize, const LEAK: bool>(p: &NeuronParams, rng: &mut rand::rngs::StdRng) {
        for _ in 0..2000 {
            let v: [f32; N] = std::array::from_fn(|_| rng.random_range(-1.5..1.5));
            let acc: [f32; N] =
                std::array::from_fn(|_| if rng.random_bool(0.5) { rng.random_range(-1.0..1.5) } else { 0.0 });
            let behind = rng.random_range(-1..6);
            let (mut v1, mut a1, mut v2, mut a2) = (v, acc, v, acc);
            let portable = lif_masks::<N, LEAK>(p, &mut v1, &mut a1, behind);
            let simd = sse::lif_lanes::<N, LEAK>(p, &mut v2, &mut a2, behind);
            assert_eq!(portable, simd, "spikes and carry; v {v:?}, input {acc:?}, behind {behind}");
            assert_eq!(v1.map(f32::to_bits), v2.map(f32::to_bits), "membranes");
            assert_eq!(a1.map(f32::to_bits), a2.map(f32::to_bits), "accumulators emptied");
        }
    }

    #[test]
    fn sse_lanes_equal_the_portable_update() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let mut leaky = NeuronParams::lif(0.85).with_reset(Reset::Subtract);
        leaky.v_leak = 0.3;
        for p in [
            NeuronParams::lif(0.9),
            NeuronParams::lif(0.9).with_reset(Reset::Subtract),
            NeuronParams::integrate_and_fire(),
        ] {
            assert_eq!(p.leak_term().to_bits(), 0);
            same_as_portable::<8, false>(&p, &mut rng);
            same_as_portable::<16, false>(&p, &mut rng);
        }
        same_as_portable::<8, true>(&leaky, &mut rng);
        same_as_portable::<16, true>(&leaky, &mut rng);
    }
}
