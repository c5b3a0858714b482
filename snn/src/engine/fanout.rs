//! The fan-out maps and how inputs reach them: fixed-size index sets, a convolution's outputs
//! bucketed by channel, per-pixel target lists, and the fan-in of a step's inputs and spikes.

use super::LayerState;
use super::compile::{Compiled, DENSE_BLOCK, Fan, conv_positions, pool_targets};

/// A fixed-size set of indices, iterated in ascending order.
#[derive(Debug, Clone, Default)]
pub(super) struct BitSet {
    pub(super) words: Vec<u64>,
    pub(super) any: bool,
}

impl BitSet {
    pub(super) fn new(n: usize) -> Self {
        Self { words: vec![0; n.div_ceil(64)], any: false }
    }
    #[inline]
    pub(super) fn insert(&mut self, i: usize) {
        self.words[i >> 6] |= 1 << (i & 63);
        self.any = true;
    }
    /// [`BitSet::insert`] without the check of `i`.
    ///
    /// # Safety
    /// `i` must be below `64 * words.len()`.
    #[inline(always)]
    pub(super) unsafe fn insert_unchecked(&mut self, i: usize) {
        // SAFETY: the caller's contract.
        unsafe { *self.words.get_unchecked_mut(i >> 6) |= 1 << (i & 63) };
        self.any = true;
    }
    /// Empties the set.
    #[inline]
    pub(super) fn clear(&mut self) {
        if self.any {
            self.words.fill(0);
            self.any = false;
        }
    }
    /// Removes the members from `n` on (none, in a correct caller: the walks that index state
    /// without a check call it first).
    #[inline]
    pub(super) fn keep_below(&mut self, n: usize) {
        let w = n >> 6;
        if let Some(word) = self.words.get_mut(w) {
            *word &= (1u64 << (n & 63)) - 1;
            self.words[w + 1..].fill(0);
        }
    }
    /// Moves every member of `other` (of the same size) into this set, a word at a time.
    #[inline]
    pub(super) fn take_all(&mut self, other: &mut BitSet) {
        debug_assert_eq!(self.words.len(), other.words.len(), "sets of one size");
        if other.any {
            for (w, o) in self.words.iter_mut().zip(&mut other.words) {
                *w |= std::mem::take(o);
            }
            self.any = true;
            other.any = false;
        }
    }
    /// Calls `f` on every member in ascending order and empties the set.
    #[inline(always)]
    pub(super) fn drain(&mut self, mut f: impl FnMut(usize)) {
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

/// The positions a convolution's fan-ins reach in a step, one byte each (0, or 0xFF once
/// reached), folded into the layer's [`BitSet`] of touched positions before the step is evaluated
/// ([`Marks::fold_into`]). Marking a byte is a plain store; setting a bit is a load, an or and a
/// store, and consecutive targets mostly fall in the same 64 positions, so each target's mark
/// waited on the last one's store (the peer benchmark's engine ran about 4.6% faster with bytes;
/// docs/engine.md, "the 2026-12-04 14:33Z session").
#[derive(Debug, Clone)]
pub(super) struct Marks {
    /// A multiple of 64 bytes, so that each 64 fold into one word of the set.
    bytes: super::Lines<u8>,
    pub(super) any: bool,
}

impl Marks {
    pub(super) fn new(n: usize) -> Self {
        Self { bytes: super::lines(0, n.next_multiple_of(64)), any: false }
    }

    /// How many positions the marks hold.
    #[inline]
    pub(super) fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Marks position `pos` (the caller sets `any`).
    ///
    /// # Safety
    /// `pos < self.len()`.
    #[inline(always)]
    pub(super) unsafe fn mark_unchecked(&mut self, pos: usize) {
        // SAFETY: the caller's contract.
        unsafe { *self.bytes.get_unchecked_mut(pos) = 0xFF };
    }

    /// Unmarks every position.
    #[inline]
    pub(super) fn clear(&mut self) {
        if self.any {
            self.bytes.fill(0);
            self.any = false;
        }
    }

    /// Adds the marked positions to `set` (of at least as many positions as the marks hold, a
    /// multiple of 64) and unmarks them.
    ///
    /// # Panics
    /// If `set` holds fewer positions than the marks.
    #[inline]
    pub(super) fn fold_into(&mut self, set: &mut BitSet) {
        if !self.any {
            return;
        }
        assert!(set.words.len() * 64 >= self.bytes.len(), "a set of the marks' positions");
        #[cfg(target_arch = "x86_64")]
        if super::simd::avx2() {
            // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
            unsafe { self.fold_avx2(set) };
            return;
        }
        self.fold_portable(set);
    }

    /// [`Marks::fold_into`] a byte at a time.
    fn fold_portable(&mut self, set: &mut BitSet) {
        for (w, chunk) in set.words.iter_mut().zip(self.bytes.chunks_exact_mut(64)) {
            let mut bits = 0u64;
            for (k, m) in chunk.iter_mut().enumerate() {
                bits |= u64::from(*m >> 7) << k;
                *m = 0;
            }
            *w |= bits;
        }
        set.any = true;
        self.any = false;
    }

    /// [`Marks::fold_into`] 32 bytes at a time (their top bits gathered by `movemask`): the
    /// same set.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    fn fold_avx2(&mut self, set: &mut BitSet) {
        use std::arch::x86_64::{
            __m256i, _mm256_loadu_si256, _mm256_movemask_epi8, _mm256_setzero_si256, _mm256_storeu_si256,
        };
        for (w, chunk) in set.words.iter_mut().zip(self.bytes.chunks_exact_mut(64)) {
            let at = chunk.as_mut_ptr().cast::<__m256i>();
            // SAFETY: `chunk` is 64 bytes, two unaligned 32-byte loads and stores inside it.
            unsafe {
                let lo = _mm256_movemask_epi8(_mm256_loadu_si256(at)) as u32;
                let hi = _mm256_movemask_epi8(_mm256_loadu_si256(at.add(1))) as u32;
                if lo | hi != 0 {
                    _mm256_storeu_si256(at, _mm256_setzero_si256());
                    _mm256_storeu_si256(at.add(1), _mm256_setzero_si256());
                    *w |= u64::from(lo) | (u64::from(hi) << 32);
                }
            }
        }
        set.any = true;
        self.any = false;
    }
}

/// A convolution's outputs of one step sorted by channel: the positions (and, for identity layers,
/// values) of channel `ch` are at `ch * plane ..` in order of arrival. Fixed-size, so that adding
/// one is a store and an increment.
#[derive(Debug, Clone)]
pub(super) struct Buckets {
    pub(super) plane: usize,
    pub(super) len: Vec<u32>,
    pub(super) pos: Vec<u32>,
    pub(super) val: Vec<f32>,
    /// Scratch: the positions that fired this step (one slot a position, padded to a multiple
    /// of 8)...
    pub(super) fired_pos: super::Lines<u32>,
    /// ... and their channels that fired, as bits.
    pub(super) fired_mask: super::Lines<u32>,
}

/// Empty, without allocating (what a layer's buckets are while taken out of its state).
impl Default for Buckets {
    fn default() -> Self {
        Self {
            plane: 0,
            len: Vec::new(),
            pos: Vec::new(),
            val: Vec::new(),
            fired_pos: super::Lines::new(0),
            fired_mask: super::Lines::new(0),
        }
    }
}

impl Buckets {
    pub(super) fn new(channels: usize, plane: usize, values: bool) -> Self {
        Self {
            plane,
            len: vec![0; channels],
            // eight slots of slack: `simd::avx::push_masks` stores eight lanes at a time
            pos: vec![0; channels * plane + 8],
            val: vec![0.0; if values { channels * plane } else { 0 }],
            fired_pos: super::lines(0, plane.next_multiple_of(8)),
            fired_mask: super::lines(0, plane.next_multiple_of(8)),
        }
    }
    /// A spike at `pos` of channel `ch`; each position comes at most once per channel and step.
    #[inline(always)]
    pub(super) fn push(&mut self, ch: usize, pos: u32) {
        let k = ch * self.plane + self.len[ch] as usize;
        self.pos[k] = pos;
        self.len[ch] += 1;
    }
    /// The spikes of the first `n` positions of `fired_pos` (ascending), whose channels that
    /// fired are the bits of `fired_mask`, channel by channel, without a branch per spike: every
    /// position's next slot gets the position and only the channels that fired advance. Each
    /// position comes at most once, so a channel's next slot is always inside its plane: it is
    /// full only after the last one. Four channels a pass (`N` a multiple of 4), so that their
    /// counts advance side by side. [`super::simd::avx::push_masks`] does the same eight
    /// positions a step.
    #[inline(always)]
    pub(super) fn push_masks<const N: usize>(&mut self, n: usize) {
        const { assert!(N.is_multiple_of(4), "channels in fours") };
        let plane = self.plane;
        let fired = self.fired_pos[..n].iter().zip(&self.fired_mask[..n]);
        for ch in (0..N).step_by(4) {
            let start: [usize; 4] = std::array::from_fn(|j| (ch + j) * plane + self.len[ch + j] as usize);
            let mut k = [0usize; 4];
            for (&pos, &bits) in fired.clone() {
                for j in 0..4 {
                    self.pos[start[j] + k[j]] = pos;
                    k[j] += ((bits >> (ch + j)) & 1) as usize;
                }
            }
            for (j, k) in k.iter().enumerate() {
                self.len[ch + j] += *k as u32;
            }
        }
    }
    #[inline(always)]
    pub(super) fn push_value(&mut self, ch: usize, pos: u32, x: f32) {
        let k = ch * self.plane + self.len[ch] as usize;
        self.val[k] = x;
        self.push(ch, pos);
    }
    #[inline]
    pub(super) fn positions(&self, ch: usize) -> &[u32] {
        &self.pos[ch * self.plane..ch * self.plane + self.len[ch] as usize]
    }
    #[inline]
    pub(super) fn values(&self, ch: usize) -> &[f32] {
        &self.val[ch * self.plane..ch * self.plane + self.len[ch] as usize]
    }
    #[inline]
    pub(super) fn clear(&mut self) {
        self.len.iter_mut().for_each(|n| *n = 0);
    }
    /// How many spikes the buckets hold.
    #[inline]
    pub(super) fn count(&self) -> usize {
        self.len.iter().map(|&n| n as usize).sum()
    }
}

/// Where a convolution's inputs reach. The output positions depend on an input's pixel, not its
/// channel, so one list per pixel serves every channel (small enough to stay in cache): pixel
/// `p`'s targets are `targets[offsets[p]..offsets[p + 1]]`, each (output position, weight
/// offset within the input channel's block of `channel_stride` weights).
///
/// The lists are checked once, when they are made, so that the fan-ins ([`ConvFanIn`]) index
/// without a bounds check per target: `offsets` has one entry per pixel and one more, ascending
/// from 0 to `targets.len()`; every target's position is below `out_positions` and its weight
/// offset leaves room for `out_channels` weights in the channel's block.
#[derive(Debug, Clone)]
pub(super) struct ConvTargets {
    n_inputs: usize,
    plane: usize,
    /// `ceil(2^32 / plane)`, when `i / plane == (i * plane_recip) >> 32` for every input `i` (a
    /// division per input event costs more than the rest of finding its list).
    plane_recip: Option<u64>,
    channel_stride: usize,
    /// The weights every input channel's block takes: `n_inputs / plane * channel_stride`.
    n_weights: usize,
    out_positions: usize,
    out_channels: usize,
    offsets: Vec<u32>,
    targets: Vec<(u32, u32)>,
}

impl ConvTargets {
    /// # Panics
    /// If the lists break the rules above (a bug in the caller, which builds them from the
    /// convolution's shape).
    pub(super) fn new(
        [n_inputs, plane]: [usize; 2],
        channel_stride: usize,
        [out_positions, out_channels]: [usize; 2],
        offsets: Vec<u32>,
        targets: Vec<(u32, u32)>,
    ) -> Self {
        assert!(plane > 0 && n_inputs.is_multiple_of(plane), "{n_inputs} inputs in planes of {plane}");
        assert!(
            offsets.len() == plane + 1
                && offsets[0] == 0
                && offsets.windows(2).all(|w| w[0] <= w[1])
                && offsets[plane] as usize == targets.len(),
            "one ascending offset per pixel and one more, from 0 to the {} targets",
            targets.len()
        );
        assert!(
            targets
                .iter()
                .all(|&(pos, w)| (pos as usize) < out_positions && w as usize + out_channels <= channel_stride),
            "targets inside the output plane of {out_positions} and inside the channel's {channel_stride} weights"
        );
        Self {
            n_inputs,
            plane,
            plane_recip: plane_recip(n_inputs, plane),
            channel_stride,
            n_weights: n_inputs / plane * channel_stride,
            out_positions,
            out_channels,
            offsets,
            targets,
        }
    }

    /// Input `i`'s targets and the offset of its channel's weights.
    ///
    /// # Panics
    /// If `i` is not one of the convolution's inputs.
    #[inline(always)]
    pub(super) fn of(&self, i: usize) -> (&[(u32, u32)], usize) {
        assert!(i < self.n_inputs, "input {i} of a convolution of {} inputs", self.n_inputs);
        // SAFETY: just checked.
        unsafe { self.of_unchecked(i) }
    }

    /// [`ConvTargets::of`] without the check.
    ///
    /// # Safety
    /// `i` must be below `n_inputs`.
    #[inline(always)]
    unsafe fn of_unchecked(&self, i: usize) -> (&[(u32, u32)], usize) {
        let (c, p) = self.channel_and_pixel(i);
        // SAFETY: `i < n_inputs` puts the pixel `p` below `plane`.
        (unsafe { self.pixel_unchecked(p) }, c * self.channel_stride)
    }

    /// The targets of pixel `p`.
    ///
    /// # Safety
    /// `p` must be below `plane`.
    #[inline(always)]
    unsafe fn pixel_unchecked(&self, p: usize) -> &[(u32, u32)] {
        // SAFETY: `p < plane`, so `p` and `p + 1` index `offsets` (`plane + 1` entries), which
        // ascend to `targets.len()` (checked in `new`).
        unsafe {
            let (a, b) = (*self.offsets.get_unchecked(p) as usize, *self.offsets.get_unchecked(p + 1) as usize);
            self.targets.get_unchecked(a..b)
        }
    }

    /// Input `i`'s channel and its pixel in the channel's plane.
    #[inline(always)]
    fn channel_and_pixel(&self, i: usize) -> (usize, usize) {
        let c = match self.plane_recip {
            Some(m) => ((i as u64 * m) >> 32) as usize,
            None => i / self.plane,
        };
        (c, i - c * self.plane)
    }

    /// Asks the cache for input `i`'s list of targets, to be read a few inputs later.
    #[inline(always)]
    pub(super) fn prefetch(&self, i: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(&o) = self.offsets.get(self.channel_and_pixel(i).1) {
                // SAFETY: a prefetch reads nothing and faults on no address; SSE is baseline on x86_64.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                        self.targets.as_ptr().wrapping_add(o as usize).cast(),
                    )
                };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = i;
    }
}

/// `m = ceil(2^32 / d)` gives `i / d == (i * m) >> 32` for every `i < n` when `n * d <= 2^32`:
/// `i * m / 2^32 = i / d + i * e / 2^32` with `0 <= e < 1`, and `i * e / 2^32 < 1 / d` never
/// carries the fraction of `i / d` (at most `(d - 1) / d`) past the next integer.
fn plane_recip(n: usize, d: usize) -> Option<u64> {
    (d > 0 && (n as u64).checked_mul(d as u64)? <= 1 << 32).then(|| (1u64 << 32).div_ceil(d as u64))
}

/// Calls `f(out, w)` for every target of input `i` (async mode, canonical output indices).
#[inline]
pub(super) fn fan_out(fan: &Fan, i: usize, mut f: impl FnMut(usize, f32)) {
    match fan {
        Fan::Dense { n_out, stride, wt } => {
            for (o, &w) in wt[i * stride..i * stride + n_out].iter().enumerate() {
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

/// Stepped: adds input `i` with value `x` into the layer's accumulators; returns synops.
#[inline]
pub(super) fn fan_in(c: &Compiled, s: &mut LayerState, i: usize, x: f32) -> u64 {
    match &c.fan {
        Fan::Dense { n_out, stride, wt } => {
            for (a, &w) in s.acc.iter_mut().zip(&wt[i * stride..i * stride + n_out]) {
                *a += x * w;
            }
            s.touched.insert(0);
            *n_out as u64
        }
        Fan::Conv { out_c, wt, map, .. } => {
            let oc = *out_c;
            let n = match oc {
                8 => ConvFanIn::<8>::new(s, wt, map).add(i, x),
                16 => ConvFanIn::<16>::new(s, wt, map).add(i, x),
                _ => {
                    let (list, wc) = map.of(i);
                    let wt = &wt[wc..];
                    for &(pos, w) in list {
                        let (pos, w) = (pos as usize, w as usize);
                        for (a, &w) in s.acc[pos * oc..(pos + 1) * oc].iter_mut().zip(&wt[w..w + oc]) {
                            *a += x * w;
                        }
                        s.touched.insert(pos);
                    }
                    list.len()
                }
            };
            (n * oc) as u64
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

/// Dense layers of at most this many outputs keep them in registers through a step's spikes.
const DENSE_IN_REGISTERS: usize = 64;

/// Stepped: [`fan_in`] of spikes (value 1) at the inputs `spikes`, in order; returns synops.
/// Adding a weight itself is the same number as adding `1 * w`.
#[inline(always)]
pub(super) fn fan_in_spikes(c: &Compiled, s: &mut LayerState, spikes: &[u32]) -> u64 {
    if spikes.is_empty() {
        return 0;
    }
    match &c.fan {
        Fan::Dense { n_out, stride, wt } => {
            let n = *n_out;
            if n <= DENSE_IN_REGISTERS {
                // the outputs held in registers through the step's spikes (with AVX2 all of them
                // at once, so that a spike's adds form independent chains; else `DENSE_BLOCK` at a
                // time): the same adds in the same order per output as adding each spike's row to
                // them in memory, without a store and a load per spike (with a readout of a few
                // dozen outputs each add would wait on the last one's store)
                #[cfg(target_arch = "x86_64")]
                if super::simd::avx2() {
                    let (acc, stride) = (&mut s.acc[..n], *stride);
                    // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
                    unsafe {
                        match stride / 8 {
                            2 => super::simd::avx::dense_spikes::<2>(acc, wt, stride, spikes),
                            4 => super::simd::avx::dense_spikes::<4>(acc, wt, stride, spikes),
                            6 => super::simd::avx::dense_spikes::<6>(acc, wt, stride, spikes),
                            _ => super::simd::avx::dense_spikes::<8>(acc, wt, stride, spikes),
                        }
                    }
                    s.touched.insert(0);
                    return (spikes.len() * n) as u64;
                }
                for (c, chunk) in s.acc[..n].chunks_mut(DENSE_BLOCK).enumerate() {
                    let mut a = [0f32; DENSE_BLOCK];
                    a[..chunk.len()].copy_from_slice(chunk);
                    for &i in spikes {
                        let at = i as usize * stride + c * DENSE_BLOCK;
                        let w: &[f32; DENSE_BLOCK] = wt[at..at + DENSE_BLOCK].try_into().expect("a padded row");
                        for (a, &w) in a.iter_mut().zip(w) {
                            *a += w;
                        }
                    }
                    chunk.copy_from_slice(&a[..chunk.len()]);
                }
            } else {
                for &i in spikes {
                    let i = i as usize;
                    for (a, &w) in s.acc.iter_mut().zip(&wt[i * stride..i * stride + n]) {
                        *a += w;
                    }
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

/// [`fan_in_spikes`] into a convolution of `N` channels.
#[inline(never)]
pub(super) fn conv_spikes<const N: usize>(s: &mut LayerState, wt: &[f32], map: &ConvTargets, spikes: &[u32]) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if super::simd::avx2() {
        // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
        return unsafe { avx2::conv_spikes::<N>(s, wt, map, spikes) };
    }
    conv_spikes_with::<N>(s, wt, map, spikes)
}

#[inline(always)]
fn conv_spikes_with<const N: usize>(s: &mut LayerState, wt: &[f32], map: &ConvTargets, spikes: &[u32]) -> u64 {
    (ConvFanIn::<N>::new(s, wt, map).add_spikes(spikes) * N) as u64
}

/// Stepped: the spikes of a convolution left in its buckets (`Compiled::spikes_in_buckets`)
/// into the next layer, in the canonical order (channel by channel, positions ascending);
/// returns synops.
#[inline(always)]
pub(super) fn fan_in_buckets(c: &Compiled, s: &mut LayerState, b: &Buckets) -> u64 {
    match &c.fan {
        Fan::Conv { out_c: 8, wt, map, .. } => conv_buckets::<8>(s, wt, map, b),
        Fan::Conv { out_c: 16, wt, map, .. } => conv_buckets::<16>(s, wt, map, b),
        _ => unreachable!("spikes are left in buckets only before a convolution of 8 or 16 channels (`Engine::new`)"),
    }
}

/// [`fan_in_buckets`] into a convolution of `N` channels.
#[inline(never)]
fn conv_buckets<const N: usize>(s: &mut LayerState, wt: &[f32], map: &ConvTargets, b: &Buckets) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if super::simd::avx2() {
        // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
        return unsafe { avx2::conv_buckets::<N>(s, wt, map, b) };
    }
    conv_buckets_with::<N>(s, wt, map, b)
}

#[inline(always)]
fn conv_buckets_with<const N: usize>(s: &mut LayerState, wt: &[f32], map: &ConvTargets, b: &Buckets) -> u64 {
    (ConvFanIn::<N>::new(s, wt, map).add_buckets(b) * N) as u64
}

/// The step's inputs (`set`, values in `values`, both emptied) into a convolution of `N`
/// channels, in ascending order; returns synops.
#[inline(never)]
pub(super) fn conv_inputs<const N: usize>(
    s: &mut LayerState,
    wt: &[f32],
    map: &ConvTargets,
    set: &mut BitSet,
    values: &mut [f32],
) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if super::simd::avx2() {
        // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
        return unsafe { avx2::conv_inputs::<N>(s, wt, map, set, values) };
    }
    conv_inputs_with::<N>(s, wt, map, set, values)
}

#[inline(always)]
fn conv_inputs_with<const N: usize>(
    s: &mut LayerState,
    wt: &[f32],
    map: &ConvTargets,
    set: &mut BitSet,
    values: &mut [f32],
) -> u64 {
    // `set.drain` by hand: a closure would be compiled apart, without the caller's features.
    let mut n = 0;
    if !set.any {
        return 0;
    }
    // the inputs gathered a chunk at a time, so that each one's list of targets is asked for
    // `AHEAD` inputs before it is read
    const CHUNK: usize = 128;
    const AHEAD: usize = 2;
    let mut chunk = [0u32; CHUNK + 64];
    let mut len = 0;
    for (w, word) in set.words.iter_mut().enumerate() {
        len += list_bits(std::mem::take(word), (w * 64) as u32, &mut chunk[len..]);
        if len >= CHUNK {
            n += conv_inputs_chunk::<N, AHEAD>(s, wt, map, &chunk[..len], values);
            len = 0;
        }
    }
    n += conv_inputs_chunk::<N, AHEAD>(s, wt, map, &chunk[..len], values);
    set.any = false;
    (n * N) as u64
}

/// Writes `base +` the index of each bit of `bits` to `out`, ascending, and returns how many.
/// The first four are written whatever the count (past it, `out` gets indices that mean
/// nothing), so that a word of none to four members, nearly every word of a sparse set (at 1.5%
/// of inputs a step, a word holds one on average), is listed without a branch on its bits: a
/// loop per bit mispredicts its exit once a word, and whether a word is empty is a coin toss.
///
/// # Panics
/// If `out` is shorter than 64.
#[inline(always)]
fn list_bits(mut bits: u64, base: u32, out: &mut [u32]) -> usize {
    let out: &mut [u32; 64] = (&mut out[..64]).try_into().expect("room for a word");
    let count = bits.count_ones() as usize;
    for slot in &mut out[..4] {
        *slot = base + bits.trailing_zeros();
        bits &= bits.wrapping_sub(1);
    }
    if count > 4 {
        for slot in &mut out[4..count] {
            *slot = base + bits.trailing_zeros();
            bits &= bits - 1;
        }
    }
    count
}

/// Inputs `chunk` (values in `values`, emptied) into a convolution of `N` channels, each one's
/// list of targets asked for `AHEAD` inputs before it is read; returns the targets reached.
#[inline(always)]
fn conv_inputs_chunk<const N: usize, const AHEAD: usize>(
    s: &mut LayerState,
    wt: &[f32],
    map: &ConvTargets,
    chunk: &[u32],
    values: &mut [f32],
) -> usize {
    let mut fan = ConvFanIn::<N>::new(s, wt, map);
    let mut n = 0;
    for (k, &i) in chunk.iter().enumerate() {
        if let Some(&j) = chunk.get(k + AHEAD) {
            map.prefetch(j as usize);
        }
        let i = i as usize;
        n += fan.add(i, std::mem::take(&mut values[i]));
    }
    n
}

/// The convolution fan-ins compiled for AVX2 (the same operations in wider registers: the
/// numbers are the same, as no add or multiply is fused or reordered).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{BitSet, ConvTargets, LayerState};

    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(super) fn conv_spikes<const N: usize>(
        s: &mut LayerState,
        wt: &[f32],
        map: &ConvTargets,
        spikes: &[u32],
    ) -> u64 {
        super::conv_spikes_with::<N>(s, wt, map, spikes)
    }

    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(super) fn conv_buckets<const N: usize>(
        s: &mut LayerState,
        wt: &[f32],
        map: &ConvTargets,
        b: &super::Buckets,
    ) -> u64 {
        super::conv_buckets_with::<N>(s, wt, map, b)
    }

    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(super) fn conv_inputs<const N: usize>(
        s: &mut LayerState,
        wt: &[f32],
        map: &ConvTargets,
        set: &mut BitSet,
        values: &mut [f32],
    ) -> u64 {
        super::conv_inputs_with::<N>(s, wt, map, set, values)
    }
}

/// A convolution's fan-in with `N` output channels known at compile time, so that the adds
/// unroll into whole vector registers. The layer's accumulators, touched marks and weights are
/// checked once against the target lists ([`ConvTargets`]), so that each target is added without
/// a bounds check (about 20,000 targets a sample on the peer benchmark, where the checks cost 5%
/// of the engine's time).
pub(super) struct ConvFanIn<'a, const N: usize> {
    acc: &'a mut [f32],
    marks: &'a mut Marks,
    wt: &'a [f32],
    map: &'a ConvTargets,
}

impl<'a, const N: usize> ConvFanIn<'a, N> {
    /// # Panics
    /// If the layer's state or weights are smaller than `map` reaches, or the layer has other than
    /// `N` channels.
    #[inline(always)]
    pub(super) fn new(s: &'a mut LayerState, wt: &'a [f32], map: &'a ConvTargets) -> Self {
        assert!(
            map.out_channels == N
                && s.acc.len() >= map.out_positions * N
                && s.marks.len() >= map.out_positions
                && wt.len() >= map.n_weights,
            "a convolution's state and weights of the size of its target lists"
        );
        Self { acc: &mut s.acc, marks: &mut s.marks, wt, map }
    }

    /// Adds input `i` with value `x` to its targets and marks them; returns how many it
    /// reached. A spike (`x == 1`) adds the weight itself, which is the same number as `1 * w`.
    #[inline(always)]
    pub(super) fn add(&mut self, i: usize, x: f32) -> usize {
        assert!(i < self.map.n_inputs, "input {i} of a convolution of {} inputs", self.map.n_inputs);
        // SAFETY: just checked.
        unsafe { self.add_unchecked(i, x) }
    }

    /// Adds spikes at the inputs `spikes`, in order (checked once, by their maximum); returns the
    /// targets reached.
    #[inline(always)]
    pub(super) fn add_spikes(&mut self, spikes: &[u32]) -> usize {
        let n_inputs = self.map.n_inputs;
        assert!(
            spikes.iter().copied().max().is_none_or(|i| (i as usize) < n_inputs),
            "spikes of the {n_inputs} inputs"
        );
        let mut n = 0;
        for &i in spikes {
            // SAFETY: checked above.
            n += unsafe { self.add_unchecked(i as usize, 1.0) };
        }
        n
    }

    /// Adds the spikes of the layer before, left in its buckets (channel by channel, positions
    /// ascending: the canonical order of [`ConvFanIn::add_spikes`], so the same adds in the same
    /// order, without the canonical list written and read and each spike's channel and pixel
    /// taken apart again); returns the targets reached.
    ///
    /// # Panics
    /// If the buckets are not of this convolution's input planes or hold a position outside them.
    #[inline(always)]
    pub(super) fn add_buckets(&mut self, b: &Buckets) -> usize {
        let map = self.map;
        assert!(b.plane == map.plane && b.len.len() * map.plane == map.n_inputs, "buckets of the convolution's inputs");
        let mut n = 0;
        self.marks.any = true;
        for ch in 0..b.len.len() {
            let positions = b.positions(ch);
            assert!(positions.iter().copied().max().is_none_or(|p| (p as usize) < map.plane), "positions in the plane");
            for &p in positions {
                // SAFETY: `p < plane` (checked above), and `ch * channel_stride` is the offset
                // of input channel `ch < n_inputs / plane`.
                n += unsafe { self.add_list(map.pixel_unchecked(p as usize), ch * map.channel_stride, 1.0) };
            }
        }
        n
    }

    /// [`ConvFanIn::add`] without the check of `i`.
    ///
    /// # Safety
    /// `i` must be below the convolution's `n_inputs`.
    #[inline(always)]
    unsafe fn add_unchecked(&mut self, i: usize, x: f32) -> usize {
        // SAFETY: the caller's contract.
        let (list, wc) = unsafe { self.map.of_unchecked(i) };
        self.marks.any = true;
        // SAFETY: `wc` is the offset of `i`'s channel, `list` a list of `map`.
        unsafe { self.add_list(list, wc, x) }
    }

    /// Adds `x` times the weights at `wc` and the list's offsets to the list's targets and marks
    /// them (the caller sets `marks.any`).
    ///
    /// # Safety
    /// `list` must be one of the map's lists and `wc` the weight offset of one of its input
    /// channels (`c * channel_stride` for `c < n_inputs / plane`).
    #[inline(always)]
    unsafe fn add_list(&mut self, list: &[(u32, u32)], wc: usize, x: f32) -> usize {
        for &(pos, w) in list {
            let (pos, w) = (pos as usize, wc + w as usize);
            // SAFETY: `pos < out_positions` and `w + N <= wc + channel_stride` (`ConvTargets::new`),
            // with `wc = c * channel_stride` for an input channel `c < n_inputs / plane`; `new`
            // checked that `acc` holds `out_positions * N`, `marks` `out_positions` and `wt`
            // every channel's block.
            let (a, w) = unsafe {
                (
                    &mut *self.acc.as_mut_ptr().add(pos * N).cast::<[f32; N]>(),
                    &*self.wt.as_ptr().add(w).cast::<[f32; N]>(),
                )
            };
            if x == 1.0 {
                for k in 0..N {
                    a[k] += w[k];
                }
            } else {
                for k in 0..N {
                    a[k] += x * w[k];
                }
            }
            // SAFETY: as above, `pos < out_positions <= marks.len()`.
            unsafe { self.marks.mark_unchecked(pos) };
        }
        list.len()
    }
}

#[cfg(test)]
mod tests {
    use super::{BitSet, Buckets, ConvTargets, Marks, list_bits, plane_recip};

    /// A word's members are listed in ascending order for every count, none, the four written
    /// whatever the count, more than four, and all 64, at every base.
    #[test]
    fn a_words_bits_are_listed_in_order() {
        let mut words = vec![0u64, 1, 1 << 63, 0b1011, 0b1111, 0b11111, u64::MAX, 0x8000_0001_0000_0001];
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for k in 0..200 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // sparse and dense words alike
            words.push(if k % 2 == 0 { x & (x >> 11) & (x >> 23) } else { x });
        }
        for (k, &word) in words.iter().enumerate() {
            let base = 64 * k as u32;
            let want: Vec<u32> = (0..64).filter(|b| word >> b & 1 == 1).map(|b| base + b).collect();
            let mut out = [u32::MAX; 70];
            let n = list_bits(word, base, &mut out);
            assert_eq!(&out[..n], &want[..], "word {word:#x}");
        }
    }

    /// The buffers read a register at a time start on cache lines, whatever the allocator
    /// leaves around them.
    #[test]
    fn lane_buffers_start_on_cache_lines() {
        for n in [1, 7, 64, 100, 1064 * 8] {
            let b = Buckets::new(16, n, false);
            let m = Marks::new(n);
            let lines = crate::engine::lines(0.0f32, n);
            for at in [b.fired_pos.as_ptr() as usize, b.fired_mask.as_ptr() as usize, m.bytes.as_ptr() as usize] {
                assert_eq!(at % 64, 0, "{n} positions");
            }
            assert_eq!(lines.as_ptr() as usize % 64, 0);
        }
    }

    /// The lists the fan-ins index without checks are refused when they reach past the output
    /// plane, past a channel's weights, or past their own targets.
    #[test]
    fn target_lists_that_reach_outside_are_refused() {
        // two pixels, one input channel, outputs of 3 positions and 2 channels, 4 weights a channel
        let make = |offsets: Vec<u32>, targets: Vec<(u32, u32)>| {
            std::panic::catch_unwind(|| ConvTargets::new([2, 2], 4, [3, 2], offsets, targets)).is_ok()
        };
        assert!(make(vec![0, 1, 2], vec![(0, 0), (2, 2)]));
        assert!(!make(vec![0, 1, 2], vec![(0, 0), (3, 2)]), "a position past the plane");
        assert!(!make(vec![0, 1, 2], vec![(0, 0), (2, 3)]), "weights past the channel's block");
        assert!(!make(vec![0, 2, 1], vec![(0, 0), (2, 2)]), "offsets that descend");
        assert!(!make(vec![0, 1, 3], vec![(0, 0), (2, 2)]), "an offset past the targets");
        assert!(!make(vec![0, 2], vec![(0, 0), (2, 2)]), "an offset missing");
    }

    /// Marked positions fold into the set beside its members, on the portable path and the AVX2
    /// one (where the CPU has it), and the marks are empty after.
    #[test]
    fn marks_fold_into_the_set_beside_its_members() {
        let n = 150;
        let members = [3usize, 64, 149];
        let marked = [0usize, 3, 5, 63, 64, 65, 127, 128, 149];
        let want: Vec<usize> = {
            let mut w: Vec<usize> = members.iter().chain(&marked).copied().collect();
            w.sort_unstable();
            w.dedup();
            w
        };
        let mut paths: Vec<fn(&mut Marks, &mut BitSet)> = vec![Marks::fold_portable, Marks::fold_into];
        #[cfg(target_arch = "x86_64")]
        if crate::engine::simd::avx2() {
            // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
            paths.push(|m, s| unsafe { m.fold_avx2(s) });
        }
        for fold in paths {
            let mut set = BitSet::new(n);
            members.iter().for_each(|&i| set.insert(i));
            let mut marks = Marks::new(n);
            assert_eq!(marks.len(), 192);
            for &i in &marked {
                // SAFETY: every position is below 150 < 192.
                unsafe { marks.mark_unchecked(i) };
            }
            marks.any = true;
            fold(&mut marks, &mut set);
            let mut got = Vec::new();
            set.drain(|i| got.push(i));
            assert_eq!(got, want);
            assert!(!marks.any && marks.bytes.iter().all(|&b| b == 0), "the marks emptied");
        }
    }

    /// `keep_below` drops exactly the members from `n` on.
    #[test]
    fn keep_below_drops_the_members_from_n_on() {
        for n in [0, 1, 63, 64, 65, 127, 128, 150, 192] {
            let mut set = BitSet::new(192);
            for i in (0..192).step_by(7).chain([0, 63, 64, 127, 128, 191]) {
                set.insert(i);
            }
            let before: Vec<usize> = {
                let mut s = set.clone();
                let mut v = Vec::new();
                s.drain(|i| v.push(i));
                v
            };
            set.keep_below(n);
            let mut after = Vec::new();
            set.drain(|i| after.push(i));
            assert_eq!(after, before.into_iter().filter(|&i| i < n).collect::<Vec<_>>(), "n {n}");
        }
    }

    /// The multiply-and-shift gives the division's quotient for every input it is used for.
    #[test]
    fn plane_reciprocal_divides_exactly() {
        for d in (1..300).chain([1200, 4800, 65_535, 65_536]) {
            let n = (1usize << 32) / d;
            let m = plane_recip(n, d).expect("in range");
            let step = (n / 50_000).max(1);
            for i in (0..n).step_by(step).chain(n.saturating_sub(2 * d)..n) {
                assert_eq!(((i as u64 * m) >> 32) as usize, i / d, "i {i}, d {d}");
            }
        }
        assert_eq!(plane_recip(1 << 20, 1 << 13), None);
    }
}
