//! The inner loops: the membranes' update and the neurons kept near threshold (portable and AVX2),
//! fan-out, weight gradients and gathers for dense layers and convolutions.

use super::*;

/// `|x|` beyond which `surrogate`'s derivative is below `cutoff` times its peak (infinite for 0).
pub(super) fn truncation_width(surrogate: Surrogate, cutoff: f32) -> f32 {
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
pub(super) fn above(v: &[f32], low: f32, out: &mut Vec<u32>) -> usize {
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
pub(super) fn update_above<const AVX: bool>(
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
pub(super) unsafe fn avx_update_above(
    v: &mut [f32],
    u: &mut [f32],
    beta: f32,
    leak: f32,
    low: f32,
    out: &mut Vec<u32>,
) -> usize {
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
pub(super) enum Keep {
    /// `|d| < x_cut`: their surrogate derivative is kept (`x_cut`: the truncation's width).
    Within(f32),
    /// `d > 0`: they fire.
    Fired,
}

impl Keep {
    #[inline(always)]
    pub(super) fn keeps(self, d: f32) -> bool {
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
pub(super) fn pick<const AVX: bool>(
    keep: Keep,
    near: &[u32],
    dist: &[f32],
    idx: &mut Vec<u32>,
    mut val: Option<&mut Vec<f32>>,
) {
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
pub(super) unsafe fn avx_pick(
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
pub(super) fn lanes_above(x: &[f32; 4], low: f32) -> usize {
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
pub(super) const PACK4: [([u32; 4], usize); 16] = {
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
pub(super) fn axpy(y: &mut [f32], x: &[f32], a: f32) {
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
pub(super) fn axpy_width<const WIDTH: usize>(y: &mut [f32], x: &[f32], a: f32) {
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
pub(super) fn dot(a: &[f32], b: &[f32]) -> f32 {
    debug_assert_eq!(a.len(), b.len(), "a dot product of equal lengths");
    #[cfg(target_arch = "x86_64")]
    return sse_dot(a, b);
    #[cfg(not(target_arch = "x86_64"))]
    portable_dot(a, b)
}

/// [`dot`] in portable code: four running sums, so that the compiler vectorises it, and a tail.
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
#[inline(always)]
pub(super) fn portable_dot(a: &[f32], b: &[f32]) -> f32 {
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
pub(super) fn sse_dot(a: &[f32], b: &[f32]) -> f32 {
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
pub(super) fn scatter(plan: &Plan, w: &[f32], i: usize, x: f32, u: &mut [f32]) {
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
pub(super) fn weight_grad(plan: &Plan, gw: &mut [f32], i: usize, x: f32, g: &[f32]) {
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
pub(super) fn gather(plan: &Plan, w: &[f32], i: usize, g: &[f32]) -> f32 {
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
pub(super) struct ConvOf<'a> {
    pub(super) ic: usize,
    pub(super) oc: usize,
    pub(super) kk: usize,
    pub(super) offsets: &'a [u32],
    pub(super) targets: &'a [(u32, u32)],
}

impl ConvOf<'_> {
    #[inline(always)]
    pub(super) fn new<const WIDTH: usize>(plan: &Plan) -> ConvOf<'_> {
        let Kernel::Conv { ic, oc, kk, offsets, targets } = &plan.kernel else {
            unreachable!("called for convolutions only");
        };
        ConvOf { ic: *ic, oc: if WIDTH == 0 { *oc } else { WIDTH }, kk: *kk, offsets, targets }
    }

    /// Input `i`'s channel and its targets (output pixel, kernel position).
    #[inline(always)]
    pub(super) fn targets_of(&self, i: usize) -> (usize, &[(u32, u32)]) {
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
pub(super) fn conv_scatter<const WIDTH: usize>(plan: &Plan, w: &[f32], i: usize, x: f32, u: &mut [f32]) {
    let conv = ConvOf::new::<WIDTH>(plan);
    let (oc, kk, (c, targets)) = (conv.oc, conv.kk, conv.targets_of(i));
    for &(q, k) in targets {
        axpy_width::<WIDTH>(&mut u[q as usize * oc..][..oc], &w[(c * kk + k as usize) * oc..][..oc], x);
    }
}

/// [`weight_grad`] for a convolution of `WIDTH` output channels (0: any).
#[inline(always)]
pub(super) fn conv_weight_grad<const WIDTH: usize>(plan: &Plan, gw: &mut [f32], i: usize, x: f32, g: &[f32]) {
    let conv = ConvOf::new::<WIDTH>(plan);
    let (oc, kk, (c, targets)) = (conv.oc, conv.kk, conv.targets_of(i));
    for &(q, k) in targets {
        axpy_width::<WIDTH>(&mut gw[(c * kk + k as usize) * oc..][..oc], &g[q as usize * oc..][..oc], x);
    }
}

/// [`gather`] for a convolution of `WIDTH` output channels (0: any).
#[inline(always)]
pub(super) fn conv_gather<const WIDTH: usize>(plan: &Plan, w: &[f32], i: usize, g: &[f32]) -> f32 {
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
pub(super) struct Workspace<'a> {
    pub(super) params: &'a Params,
    pub(super) by_input: &'a [Option<ByInput>],
    pub(super) pool: &'a mut Vec<Vec<f32>>,
}

/// Lanes of [`gather_all_conv`] and [`gather_all_dense`]: inputs gathered at once.
pub(super) const GATHER_LANES: usize = 8;

/// A layer's weights laid out for gathering [`GATHER_LANES`] inputs at once.
pub(super) enum ByInput {
    /// A convolution's, `[k][out_c][in_c]` ([`gather_all_conv`]).
    Conv(Vec<f32>),
    /// A dense layer's, `[out][in]` ([`gather_all_dense`]).
    Dense(Vec<f32>),
}

/// `w` laid out by input ([`ByInput`]): a dense layer's, and a convolution's when its input
/// channels come in whole [`GATHER_LANES`] (else `None`: [`gather`] input by input).
pub(super) fn weights_by_input(plan: &Plan, w: &[f32]) -> Option<ByInput> {
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
pub(super) fn gather_all_dense(wt: &[f32], n: usize, g: &[f32], g_in: &mut [f32]) {
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
pub(super) fn derivatives_in_place(surrogate: Surrogate, x: &mut [f32]) {
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
pub(super) fn surrogate_all(g_u: &mut [f32], sv: &[f32], go: &[f32], gr: &[f32]) {
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
pub(super) fn gather_all_conv(plan: &Plan, wt: &[f32], g: &[f32], g_in: &mut [f32]) {
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
