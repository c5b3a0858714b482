//! The stepped neuron updates: which neurons a step evaluates, a convolution position's LIF lanes
//! (portable, or in SSE registers by `super::simd`), and one neuron's update.

use super::compile::{Compiled, Fan, bias_index};
use super::fanout::{BitSet, Buckets};
#[cfg(target_arch = "x86_64")]
use super::simd::sse;
use super::{LayerState, Stats};
use crate::neuron::{NeuronKind, NeuronParams};

/// Stepped: updates the neurons that need it at step `t` (in ascending order) and collects the
/// spikes (or, for identity layers, the outputs that carry a value) in `s.spikes`; a layer with
/// `spikes_in_buckets` leaves them in `s.by_channel` instead.
///
/// Updating a neuron with zero input is exactly what the dense pass does to it, so the set
/// evaluated may be a superset of the neurons touched: whole positions of a convolution, every
/// neuron of a dense layer that received anything.
#[inline(always)]
pub(super) fn evaluate(c: &Compiled, s: &mut LayerState, t: i64, base: i64, stats: &mut Stats) {
    let n = c.n_out;
    // A recurrent bias makes the recurrent input present at every step after the first.
    let rec_bias = c.rec_bias.as_deref().filter(|_| t > base);
    let rec_on = s.rec_pending || rec_bias.is_some();
    let all = c.every_step || rec_on;
    // Recurrent input from the previous step's spikes, summed on its own.
    if rec_on && let Some(rt) = &c.rec_t {
        s.rec.iter_mut().for_each(|r| *r = 0.0);
        if s.rec_pending {
            // each previous spike reaches every neuron of the layer from its first to its last
            // non-zero weight (all of them, but in a merged ensemble): synaptic operations too
            for &j in &s.prev {
                let (lo, hi) = c.rec_span[j as usize];
                let (lo, hi) = (lo as usize, hi as usize);
                for (r, &w) in s.rec[lo..hi].iter_mut().zip(&rt[j as usize * n + lo..j as usize * n + hi]) {
                    *r += 1.0 * w;
                }
                stats.synops += (hi - lo) as u64;
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
            // the positions the fan-ins marked, as bits
            s.marks.fold_into(&mut s.touched);
            let mut by_channel = std::mem::take(&mut s.by_channel);
            // emptied here, not after the spikes are taken out: a layer that leaves its spikes in
            // the buckets (`spikes_in_buckets`) keeps them there for the next layer's fan-in
            by_channel.clear();
            // LIF and IF without bias at 8 or 16 channels: one loop compiled for the width, which
            // walks the positions to update itself.
            let lanes = c.neurons.filter(|p| p.kind != NeuronKind::CubaLif && c.bias.is_none() && rec.is_none());
            let leak = lanes.is_some_and(|p| p.leak_term().to_bits() != 0);
            let every = all.then_some(plane);
            match (lanes, oc, leak) {
                (Some(p), 8, false) => lif_positions::<8, false>(&p, s, every, t, base, &mut by_channel, stats),
                (Some(p), 8, true) => lif_positions::<8, true>(&p, s, every, t, base, &mut by_channel, stats),
                (Some(p), 16, false) => lif_positions::<16, false>(&p, s, every, t, base, &mut by_channel, stats),
                (Some(p), 16, true) => lif_positions::<16, true>(&p, s, every, t, base, &mut by_channel, stats),
                _ => {
                    schedule(s, all, plane, &mut order);
                    for &pos in &order {
                        update_position(c, s, pos as usize, oc, t, base, rec.as_deref(), &mut by_channel, stats);
                    }
                }
            }
            // Canonical order: channel by channel, positions ascending.
            if !c.spikes_in_buckets {
                for ch in 0..oc {
                    let offset = (ch * plane) as u32;
                    s.spikes.extend(by_channel.positions(ch).iter().map(|&pos| offset + pos));
                    if c.neurons.is_none() {
                        s.values.extend_from_slice(by_channel.values(ch));
                    }
                }
            }
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
#[inline]
pub(super) fn schedule(s: &mut LayerState, everything: bool, count: usize, order: &mut Vec<u32>) {
    pending(&mut s.touched, &mut s.carry, everything);
    if everything {
        order.extend(0..count as u32);
    } else {
        s.touched.drain(|p| order.push(p as u32));
    }
}

/// Readies the step's slots to update: with `everything` both sets are emptied (every slot is
/// updated), else the carried slots join the touched ones, which are then the slots to update.
#[inline]
fn pending(touched: &mut BitSet, carry: &mut BitSet, everything: bool) {
    if everything {
        touched.clear();
        carry.clear();
    } else {
        touched.take_all(carry);
    }
}

/// A convolution's position `pos` at step `t`: all its channels, state at `pos * oc + ch`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn update_position(
    c: &Compiled,
    s: &mut LayerState,
    pos: usize,
    oc: usize,
    t: i64,
    base: i64,
    rec: Option<&[f32]>,
    out: &mut Buckets,
    stats: &mut Stats,
) {
    let start = pos * oc;
    // the recurrent input is C-order: channel `ch` of this position is `ch * plane + pos`
    let plane = s.v.len() / oc;
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
    let lif = p.kind != NeuronKind::CubaLif && c.bias.is_none() && rec.is_none();
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
            if let Some(r) = rec {
                u += r[ch * plane + pos];
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
pub(super) fn lif_position(
    p: &NeuronParams,
    v: &mut [f32],
    acc: &mut [f32],
    behind: i64,
    pos: u32,
    out: &mut Buckets,
) -> bool {
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
pub(super) fn above<const N: usize>(x: &[f32; N], th: f32) -> u32 {
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
/// with `N` channels: the neuron parameters stay in registers across positions. The positions
/// that fired are kept as (position, channels as bits), without a branch (which mispredicts
/// often: whether a position fires varies), and bucketed by channel after the loop
/// ([`Buckets::push_masks`]). On CPUs with AVX2 the whole loop is compiled for it, a
/// position's lanes are updated eight to a register, and the positions are bucketed eight at a
/// time (`simd::avx::push_masks`).
#[inline(never)]
pub(super) fn lif_positions<const N: usize, const LEAK: bool>(
    p: &NeuronParams,
    s: &mut LayerState,
    every: Option<usize>,
    t: i64,
    base: i64,
    out: &mut Buckets,
    stats: &mut Stats,
) {
    #[cfg(target_arch = "x86_64")]
    if super::simd::avx2() {
        // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
        return unsafe { lif_positions_avx2::<N, LEAK>(p, s, every, t, base, out, stats) };
    }
    lif_positions_with::<N, LEAK, false>(p, s, every, t, base, out, stats)
}

/// [`lif_positions`] compiled for AVX2 (the same operations: nothing is fused or reordered).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,popcnt")]
fn lif_positions_avx2<const N: usize, const LEAK: bool>(
    p: &NeuronParams,
    s: &mut LayerState,
    every: Option<usize>,
    t: i64,
    base: i64,
    out: &mut Buckets,
    stats: &mut Stats,
) {
    lif_positions_with::<N, LEAK, true>(p, s, every, t, base, out, stats)
}

/// `AVX`: the lanes in AVX registers (the caller is compiled for AVX2).
#[inline(always)]
fn lif_positions_with<const N: usize, const LEAK: bool, const AVX: bool>(
    p: &NeuronParams,
    s: &mut LayerState,
    every: Option<usize>,
    t: i64,
    base: i64,
    out: &mut Buckets,
    stats: &mut Stats,
) {
    let LayerState { v, acc, last, carry, touched, .. } = s;
    // The positions to update, ascending (as `schedule` gives them): every one, or those
    // touched this step or carried from the last.
    pending(touched, carry, every.is_some());
    // The state is checked once against the plane, so that a position's update indexes it
    // without a check (a bounds check per position cost 2% of the engine's time); no position
    // past the plane is ever marked, and none is walked.
    let plane = last.len();
    assert!(
        v.len() >= plane * N
            && acc.len() >= plane * N
            && out.fired_pos.len() >= plane
            && out.fired_mask.len() >= plane
            && carry.words.len() * 64 >= plane
            && every.is_none_or(|n| n <= plane),
        "a convolution's state of its plane's size"
    );
    touched.keep_below(plane);
    let mut steps = 0u64;
    let mut n_fired = 0;
    #[cfg(target_arch = "x86_64")]
    let factors = super::simd::missed_factors(p.beta);
    // one position's update (a macro, not a closure: a closure is compiled apart, without the
    // caller's AVX2)
    macro_rules! one {
        ($pos:expr) => {{
            let pos: u32 = $pos;
            let k = pos as usize * N;
            // SAFETY: `pos < plane` (the positions walked are below it) and the state holds the
            // plane (both checked above).
            let (v, acc, l) = unsafe {
                (
                    &mut *v.as_mut_ptr().add(k).cast::<[f32; N]>(),
                    &mut *acc.as_mut_ptr().add(k).cast::<[f32; N]>(),
                    last.get_unchecked_mut(pos as usize),
                )
            };
            let behind = if *l < base {
                // fresh since the last reset (a LIF's synaptic current stays unused)
                v.fill(0.0);
                fresh_steps(p, t, base)
            } else {
                t - *l - 1
            };
            *l = t;
            steps += (behind.max(0) + 1) as u64;
            #[cfg(target_arch = "x86_64")]
            let (fired, carried) = if AVX && (N == 8 || N == 16) {
                // SAFETY: `AVX` is set only by `lif_positions_avx2`, which runs where AVX2, popcnt and BMI1 are.
                unsafe { super::simd::avx::lif_lanes::<N, LEAK>(p, v, acc, behind, &factors) }
            } else {
                lif_lanes::<N, LEAK>(p, v, acc, behind)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let (fired, carried) = lif_lanes::<N, LEAK>(p, v, acc, behind);
            // SAFETY: each position is walked once, so `n_fired` counts positions before this
            // one, fewer than the plane; `pos` is inside the carried set (checked above).
            unsafe {
                *out.fired_pos.get_unchecked_mut(n_fired) = pos;
                *out.fired_mask.get_unchecked_mut(n_fired) = fired;
            }
            n_fired += (fired != 0) as usize;
            if carried {
                // SAFETY: as above.
                unsafe { carry.insert_unchecked(pos as usize) };
            }
        }};
    }
    match every {
        Some(n) => {
            for pos in 0..n as u32 {
                one!(pos)
            }
        }
        None => {
            // the set walked by hand and emptied
            if touched.any {
                for (w, word) in touched.words.iter_mut().enumerate() {
                    let mut bits = std::mem::take(word);
                    while bits != 0 {
                        one!((w * 64) as u32 + bits.trailing_zeros());
                        bits &= bits - 1;
                    }
                }
                touched.any = false;
            }
        }
    }
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is set only by `lif_positions_avx2`, which runs where AVX2, popcnt and BMI1 are.
        unsafe { super::simd::avx::push_masks::<N>(out, n_fired) };
    } else {
        out.push_masks::<N>(n_fired);
    }
    #[cfg(not(target_arch = "x86_64"))]
    out.push_masks::<N>(n_fired);
    stats.neuron_updates += steps * N as u64;
}

/// [`lif_position`] with `N <= 32` channels known at compile time: the loops unroll into whole
/// vector registers and the spike and carry masks come from vector compares. Returns the lanes
/// that fired (bits) and whether any lane must be looked at next step.
///
/// `LEAK = false` is for a resting level of exactly +0: the terms `+ leak + 0.0` are left out,
/// which changes nothing but the sign of a membrane at zero (`-0.0` against `+0.0`, equal in
/// every comparison), and shortens each step's chain of dependent operations by one add.
#[inline(always)]
pub(super) fn lif_lanes<const N: usize, const LEAK: bool>(
    p: &NeuronParams,
    v: &mut [f32; N],
    acc: &mut [f32; N],
    behind: i64,
) -> (u32, bool) {
    #[cfg(target_arch = "x86_64")]
    if N.is_multiple_of(4) && N <= 16 {
        return sse::lif_lanes::<N, LEAK>(p, v, acc, behind);
    }
    lif_masks::<N, LEAK>(p, v, acc, behind)
}

/// The update of [`lif_lanes`] in portable code: returns the lanes that fired (bits) and
/// whether any lane must be looked at next step.
#[inline(always)]
pub(super) fn lif_masks<const N: usize, const LEAK: bool>(
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

/// The steps a neuron untouched since its stream's start (step `base`, at zero) must catch up
/// before step `t`: none when zero is its resting level (nothing changes), else every one, as
/// the membrane drifts towards a resting level that is not zero.
#[inline]
pub(super) fn fresh_steps(p: &NeuronParams, t: i64, base: i64) -> i64 {
    if p.leak_term() == 0.0 { 0 } else { t - base }
}

/// One neuron's update at step `t`: neuron `o` (canonical), accumulator slot `k`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn update(
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
