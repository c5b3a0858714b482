//! The LIF lanes of a convolution position in SSE registers, four channels each (SSE is part of
//! the x86-64 baseline), or in AVX registers, eight each, where the CPU has AVX2; both tested bit
//! for bit against the portable update.

/// Whether this CPU runs the AVX2 paths: AVX2, and the bit instructions they are also compiled
/// for (`popcnt`; BMI1's `blsr`, `tzcnt`), which every AVX2 CPU has. Without `popcnt` a count of
/// bits is a dozen instructions (detected at run time; std caches the answer).
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("popcnt")
        && std::arch::is_x86_feature_detected!("bmi1")
}

/// For each set of eight lanes (as the bits of a byte), the lanes in it in ascending order, then
/// zeros: the permutation that packs the chosen lanes of an eight-lane register to its front
/// (`_mm256_permutevar8x32_*` on x86-64). The engine buckets spikes with it; the trainer
/// (`learn::sparse`) lists the neurons near threshold with it. On a 32-byte boundary: each row
/// is 32 bytes, so no row's load straddles two cache lines.
#[repr(align(32))]
pub struct PackedLanes(pub [[u32; 8]; 256]);

/// [`PackedLanes`], built once.
pub static PACKED_LANES: PackedLanes = PackedLanes(packed_lanes());

/// The table of [`PackedLanes`].
const fn packed_lanes() -> [[u32; 8]; 256] {
    let mut t = [[0u32; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let (mut j, mut k) = (0, 0);
        while j < 8 {
            if (m >> j) & 1 == 1 {
                t[m][k] = j as u32;
                k += 1;
            }
            j += 1;
        }
        m += 1;
    }
    t
}

/// Missed steps caught up without a branch (see [`sse::lif_lanes`]).
#[cfg(target_arch = "x86_64")]
const SURE: usize = 4;

/// For each count of missed steps `b` up to [`SURE`], the factors of the first `SURE` catch-up
/// steps: `beta` for a step missed, 1 (the same number) for one not. Built once per layer and
/// step, so that a position without a resting level catches up by `SURE` multiplies by loaded
/// factors, without building a mask per step ([`avx::lif_lanes`]).
#[cfg(target_arch = "x86_64")]
pub(in crate::engine) fn missed_factors(beta: f32) -> [[f32; SURE]; SURE + 1] {
    std::array::from_fn(|b| std::array::from_fn(|j| if j < b { beta } else { 1.0 }))
}

#[cfg(target_arch = "x86_64")]
pub(in crate::engine) mod sse {
    use crate::neuron::NeuronParams;
    use std::arch::x86_64::{
        __m128, _mm_add_ps, _mm_and_ps, _mm_andnot_ps, _mm_castsi128_ps, _mm_cmpgt_ps, _mm_loadu_ps, _mm_movemask_ps,
        _mm_mul_ps, _mm_or_ps, _mm_set1_epi32, _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps, _mm_sub_ps,
    };

    use super::SURE;

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

    /// The same floating-point operations as `lif_masks` (the portable update), four lanes at a time; returns
    /// the lanes that fired (bits) and whether any lane must be looked at next step.
    #[inline(always)]
    pub(in crate::engine) fn lif_lanes<const N: usize, const LEAK: bool>(
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
            // The steps missed, the first `SURE` of them without a branch (how many varies from
            // position to position, so a loop's exit mispredicts often): a step not missed
            // multiplies by 1 (without a resting level) or keeps the lanes as they are.
            let behind = behind.max(0);
            let one = _mm_set1_ps(1.0);
            for j in 0..SURE {
                let missed = (j as i64) < behind;
                let keep = _mm_castsi128_ps(_mm_set1_epi32(-(missed as i32)));
                if LEAK {
                    for r in x.iter_mut().take(N / 4) {
                        let stepped = leak_step::<true>(beta, leak, *r, zero);
                        *r = _mm_or_ps(_mm_and_ps(keep, stepped), _mm_andnot_ps(keep, *r));
                    }
                } else {
                    let m = _mm_or_ps(_mm_and_ps(keep, beta), _mm_andnot_ps(keep, one));
                    for r in x.iter_mut().take(N / 4) {
                        *r = _mm_mul_ps(m, *r);
                    }
                }
            }
            for _ in SURE as i64..behind {
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

/// [`sse::lif_lanes`] eight lanes a register, for CPUs with AVX2 (the same operations, none fused).
#[cfg(target_arch = "x86_64")]
pub(in crate::engine) mod avx {
    use crate::engine::fanout::Buckets;
    use crate::neuron::NeuronParams;
    use std::arch::x86_64::{
        __m256, __m256i, _CMP_GT_OQ, _mm_cvtsi32_si128, _mm256_add_ps, _mm256_blendv_ps, _mm256_broadcast_ss,
        _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_movemask_ps, _mm256_mul_ps,
        _mm256_permutevar8x32_epi32, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setzero_ps, _mm256_sll_epi32,
        _mm256_storeu_ps, _mm256_storeu_si256, _mm256_sub_ps,
    };

    #[inline(always)]
    fn load(x: &[f32], q: usize) -> __m256 {
        let x: &[f32; 8] = x[8 * q..8 * q + 8].try_into().expect("eight lanes");
        // SAFETY: `x` is eight readable f32s; unaligned loads are allowed; AVX is present
        // wherever this module is called (its callers are compiled for AVX2).
        unsafe { _mm256_loadu_ps(x.as_ptr()) }
    }

    #[inline(always)]
    fn store(x: &mut [f32], q: usize, r: __m256) {
        let x: &mut [f32; 8] = (&mut x[8 * q..8 * q + 8]).try_into().expect("eight lanes");
        // SAFETY: `x` is eight writable f32s; unaligned stores are allowed; AVX as in `load`.
        unsafe { _mm256_storeu_ps(x.as_mut_ptr(), r) }
    }

    /// The update of `lif_masks` for `N` = 8 or 16 lanes; returns the lanes that fired (bits) and
    /// whether any lane must be looked at next step. `factors` is `missed_factors(p.beta)`.
    ///
    /// # Safety
    /// The CPU must have AVX2, popcnt and BMI1 ([`avx2`](crate::engine::avx2)).
    #[inline]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(in crate::engine) unsafe fn lif_lanes<const N: usize, const LEAK: bool>(
        p: &NeuronParams,
        v: &mut [f32; N],
        acc: &mut [f32; N],
        behind: i64,
        factors: &[[f32; super::SURE]; super::SURE + 1],
    ) -> (u32, bool) {
        const { assert!(N == 8 || N == 16, "eight or sixteen lanes") };
        let beta = _mm256_set1_ps(p.beta);
        let leak = _mm256_set1_ps(p.leak_term());
        let th = _mm256_set1_ps(p.threshold());
        let zero = _mm256_setzero_ps();
        let subtract = p.reset == crate::neuron::Reset::Subtract;
        let after_zero = _mm256_set1_ps(p.v_reset);
        let step = |x: __m256, u: __m256| {
            if LEAK {
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(beta, x), leak), u)
            } else {
                _mm256_add_ps(_mm256_mul_ps(beta, x), u)
            }
        };
        let mut x = [zero; 2];
        for (q, r) in x.iter_mut().enumerate().take(N / 8) {
            *r = load(v, q);
        }
        // The missed steps, the first `SURE` without a branch, as in `sse::lif_lanes`: without a
        // resting level by the factors for this count of missed steps (a table lookup instead
        // of a mask built per step: 2% faster on the peer benchmark).
        let behind = behind.max(0);
        if LEAK {
            for j in 0..super::SURE {
                let keep = _mm256_castsi256_ps(_mm256_set1_epi32(-(((j as i64) < behind) as i32)));
                for r in x.iter_mut().take(N / 8) {
                    *r = _mm256_blendv_ps(*r, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(beta, *r), leak), zero), keep);
                }
            }
        } else {
            let row = &factors[behind.min(super::SURE as i64) as usize];
            for f in row {
                let m = _mm256_broadcast_ss(f);
                for r in x.iter_mut().take(N / 8) {
                    *r = _mm256_mul_ps(m, *r);
                }
            }
        }
        for _ in super::SURE as i64..behind {
            for r in x.iter_mut().take(N / 8) {
                *r = if LEAK {
                    _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(beta, *r), leak), zero)
                } else {
                    _mm256_mul_ps(beta, *r)
                };
            }
        }
        let (mut fired, mut carry) = (0u32, 0i32);
        for (q, &xq) in x.iter().enumerate().take(N / 8) {
            let u = load(acc, q);
            store(acc, q, zero);
            let vn = step(xq, u);
            let m = _mm256_cmp_ps::<_CMP_GT_OQ>(vn, th);
            let after = if subtract { _mm256_sub_ps(vn, th) } else { after_zero };
            let nv = _mm256_blendv_ps(vn, after, m);
            store(v, q, nv);
            fired |= (_mm256_movemask_ps(m) as u32) << (8 * q);
            let next = if LEAK {
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(beta, nv), leak), zero)
            } else {
                _mm256_mul_ps(beta, nv)
            };
            carry |= _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(next, th));
        }
        (fired, carry != 0)
    }

    /// A dense layer's spikes added to its outputs `acc` held in `B` registers of eight through
    /// all the spikes, so that a spike's adds are `B` independent chains (the portable code holds
    /// 16 outputs at a time): the same adds in the same order per output. Rows are `stride >= 8 B`
    /// weights, zero past the outputs; `acc.len() <= 8 B`.
    ///
    /// # Safety
    /// The CPU must have AVX2, popcnt and BMI1 ([`avx2`](crate::engine::avx2)).
    #[inline]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(in crate::engine) unsafe fn dense_spikes<const B: usize>(
        acc: &mut [f32],
        wt: &[f32],
        stride: usize,
        spikes: &[u32],
    ) {
        const { assert!(B >= 1 && B <= 8, "at most eight registers") };
        assert!(acc.len() <= 8 * B && 8 * B <= stride, "the outputs fit the registers and the rows");
        // the spikes checked against the rows once (a vectorised maximum), so that each row is
        // read without a check
        let rows = wt.len() / stride;
        assert!(spikes.iter().copied().max().is_none_or(|i| (i as usize) < rows), "spikes of the layer's inputs");
        let mut padded = [0f32; 64];
        padded[..acc.len()].copy_from_slice(acc);
        let mut a = [_mm256_setzero_ps(); B];
        for (q, r) in a.iter_mut().enumerate() {
            *r = load(&padded, q);
        }
        for &i in spikes {
            // SAFETY: `i < rows`, so the row's `8 B <= stride` weights are inside `wt`; unaligned
            // loads are allowed; AVX as in `load`.
            let row = unsafe { wt.as_ptr().add(i as usize * stride) };
            for (q, r) in a.iter_mut().enumerate() {
                *r = _mm256_add_ps(*r, unsafe { _mm256_loadu_ps(row.add(8 * q)) });
            }
        }
        for (q, &r) in a.iter().enumerate() {
            store(&mut padded, q, r);
        }
        let n = acc.len();
        acc.copy_from_slice(&padded[..n]);
    }

    /// [`Buckets::push_masks`] eight positions a step: for each channel, the positions whose bit
    /// is set are packed to the front of a register (a permutation from
    /// [`PACKED_LANES`](super::PACKED_LANES)) and all eight lanes stored at the channel's next
    /// slot, which advances by the number packed. The same positions in the same order; the lanes
    /// past them land in slots not yet filled (the buckets' eight slots of slack, or the next
    /// channel's, filled after).
    ///
    /// # Safety
    /// The CPU must have AVX2, popcnt and BMI1 ([`avx2`](crate::engine::avx2)).
    #[inline]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(in crate::engine) unsafe fn push_masks<const N: usize>(b: &mut Buckets, n: usize) {
        const { assert!(N <= 32, "at most 32 channels") };
        debug_assert!(b.len[..N].iter().all(|&k| k == 0), "lanes past a channel's spikes overwrite the next channel's");
        let n8 = n.next_multiple_of(8);
        b.fired_mask[n..n8].fill(0);
        let plane = b.plane;
        // checked once, so that the loop below reads and writes eight lanes without a check:
        // the positions in `fired_*[..n8]`, and each channel's slots from `ch * plane` to at most
        // `(ch + 1) * plane + 8` (a channel gets at most `n <= plane` positions)
        assert!(
            n <= plane && b.fired_pos.len() >= n8 && b.pos.len() >= N * plane + 8 && b.len.len() >= N,
            "buckets for {N} channels of {n} positions"
        );
        for ch in 0..N {
            let mut k = ch * plane;
            let shift = _mm_cvtsi32_si128(31 - ch as i32);
            for q in (0..n8).step_by(8) {
                // SAFETY: `q + 8 <= n8` and `k + 8 <= (ch + 1) * plane + 8` are inside the arrays
                // (checked above; unaligned loads and stores are allowed); AVX2 is present (this
                // function's contract).
                let chosen = unsafe {
                    let masks = b.fired_mask.as_ptr().add(q).cast::<__m256i>();
                    // channel `ch`'s bit moved to each lane's sign
                    let m = _mm256_sll_epi32(_mm256_loadu_si256(masks), shift);
                    let chosen = _mm256_movemask_ps(_mm256_castsi256_ps(m)) as usize;
                    let order = _mm256_loadu_si256(super::PACKED_LANES.0[chosen].as_ptr().cast::<__m256i>());
                    let p = _mm256_loadu_si256(b.fired_pos.as_ptr().add(q).cast::<__m256i>());
                    _mm256_storeu_si256(
                        b.pos.as_mut_ptr().add(k).cast::<__m256i>(),
                        _mm256_permutevar8x32_epi32(p, order),
                    );
                    chosen
                };
                k += chosen.count_ones() as usize;
            }
            b.len[ch] = (k - ch * plane) as u32;
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::super::fanout::Buckets;
    use super::super::kernels::lif_masks;
    use super::sse;
    use crate::neuron::NeuronParams;
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
            if super::avx2() {
                let (mut v3, mut a3) = (v, acc);
                // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
                let factors = super::missed_factors(p.beta);
                let wide = unsafe { super::avx::lif_lanes::<N, LEAK>(p, &mut v3, &mut a3, behind, &factors) };
                assert_eq!(portable, wide, "AVX: spikes and carry; v {v:?}, input {acc:?}, behind {behind}");
                assert_eq!(v1.map(f32::to_bits), v3.map(f32::to_bits), "AVX: membranes");
                assert_eq!(a1.map(f32::to_bits), a3.map(f32::to_bits), "AVX: accumulators emptied");
            }
        }
    }

    /// Bucketing eight positions a step gives each channel the positions of the portable code,
    /// in the same order, for any number of positions (padding included) and any masks.
    fn same_buckets<const N: usize>(rng: &mut rand::rngs::StdRng) {
        for _ in 0..300 {
            let plane = rng.random_range(1..90usize);
            let mut portable = Buckets::new(N, plane, false);
            let mut positions: Vec<u32> = (0..plane as u32).filter(|_| rng.random_bool(0.6)).collect();
            positions.retain(|_| rng.random_bool(0.9));
            let n = positions.len();
            for (k, &p) in positions.iter().enumerate() {
                portable.fired_pos[k] = p;
                // dense, sparse and full masks alike
                let density = [0.05, 0.3, 1.0][k % 3];
                portable.fired_mask[k] =
                    (0..N).fold(1 << rng.random_range(0..N), |m, ch| m | ((rng.random_bool(density) as u32) << ch));
            }
            // stale entries past `n`, which neither may read
            for k in n..portable.fired_mask.len() {
                portable.fired_pos[k] = u32::MAX;
                portable.fired_mask[k] = u32::MAX >> (32 - N);
            }
            let mut wide = portable.clone();
            portable.push_masks::<N>(n);
            if super::avx2() {
                // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
                unsafe { super::avx::push_masks::<N>(&mut wide, n) };
                for ch in 0..N {
                    assert_eq!(portable.positions(ch), wide.positions(ch), "channel {ch} of {N}, {n} positions");
                }
            }
            let spikes: usize = (0..N).map(|ch| portable.positions(ch).len()).sum();
            let expected: u32 = portable.fired_mask[..n].iter().map(|m| m.count_ones()).sum();
            assert_eq!(spikes, expected as usize);
        }
    }

    #[test]
    fn buckets_eight_positions_a_step_equal_the_portable_ones() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        same_buckets::<8>(&mut rng);
        same_buckets::<16>(&mut rng);
        same_buckets::<32>(&mut rng);
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
