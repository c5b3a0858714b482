//! A convolution computed directly, without im2col, on x86-64 CPUs with AVX2 and FMA: for a row
//! of `B` neighbouring output positions and 8 or 16 output channels, the accumulators stay in
//! vector registers while the input channels and kernel offsets stream past (one weight vector
//! loaded per offset and used for every position of the row, one input value broadcast per
//! position and used for every channel). The input is read in place from a zero-padded copy, so
//! nothing the size of im2col's columns (2.5 M values a window for the lite stem) is written and
//! read again, and two threads on two cores do not compete for memory bandwidth.
//!
//! [`super::folded`] uses it where the CPU has the features ([`available`]) and the layer's
//! output channels are a multiple of 8, at most [`MAX_CHANNELS`], and its rows at least
//! [`MIN_ROW`] positions wide; otherwise im2col and `gemm`. Both use fused multiply-adds, summing
//! in different orders: they agree to float rounding (tested against a plain sum, and the whole
//! network against burn).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, _mm256_broadcast_ss, _mm256_fmadd_ps, _mm256_loadu_ps, _mm256_setzero_ps, _mm256_storeu_ps,
};

/// The narrowest output row the direct path takes: below this a weight vector serves too few
/// positions to beat `gemm`, whose packing reuses it across the whole product (ResNet-34's last
/// stages are 3-4 positions wide).
pub(super) const MIN_ROW: usize = 8;

/// The widest layer the direct path takes. With ResNet-34's layers of 64 and 128 channels direct
/// too, its `paper` preset ran slower than by im2col and `gemm` (2026-11-28, one run of
/// `scripts/peers/resnet.sh`: 45.6 against 35.8 ms a window on a window's sparsity, 47.5 against
/// 45.6 dense, batch 1; weak evidence on a machine whose noise within one call reached 1.7x the
/// same morning, and not measured layer by layer), and the limit was set at 32. Measured again on
/// 2026-12-04 (AMD EPYC; `braille bench --model models/nominal/resnet-paper-normaug.safetensors
/// --batch 32 --threads 2 --samples 32 --density 1`, alternated with the build at 32): at 64 (the
/// stem and the first stage direct) lower in 8 of 8 pairs at batch 1 (29.0-30.7 against 31.6-34.3
/// ms a window in the last five) and in 7 of 8 at batch 32 (12.4-13.3 against 14.4-16.1); at 128
/// (the second stage too) no lower than at 64 in four pairs (28.2-31.1 against 28.5-34.0 and
/// 12.3-17.6 against 12.4-13.6).
pub(super) const MAX_CHANNELS: usize = 64;

/// Whether this CPU runs [`conv`] (AVX2 and FMA, detected at run time; std caches the answer).
pub(super) fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// A convolution's sizes: the zero-padded input `[c_in][hp][wp]`, a square kernel `k` at stride
/// `s`, the output `[c_out][oh][ow]`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Shape {
    pub c_in: usize,
    pub hp: usize,
    pub wp: usize,
    pub k: usize,
    pub s: usize,
    pub c_out: usize,
    pub oh: usize,
    pub ow: usize,
}

/// `out[co][oy][ox] += sum over ci, ky, kx of xp[ci][oy * s + ky][ox * s + kx] * w[ci][ky][kx][co]`.
///
/// # Panics
/// If a slice is shorter than the shape says, `c_out` is not a multiple of 8, or the CPU lacks
/// AVX2 or FMA ([`available`]; always so off x86-64).
pub(super) fn conv(xp: &[f32], w: &[f32], sh: Shape, out: &mut [f32]) {
    assert!(available(), "the direct convolution needs AVX2 and FMA");
    assert!(sh.c_out.is_multiple_of(8), "{} output channels, not a multiple of 8", sh.c_out);
    assert!(xp.len() >= sh.c_in * sh.hp * sh.wp, "padded input of {} values for {sh:?}", xp.len());
    assert!(w.len() >= sh.c_in * sh.k * sh.k * sh.c_out, "{} weights for {sh:?}", w.len());
    assert!(out.len() >= sh.c_out * sh.oh * sh.ow, "output of {} values for {sh:?}", out.len());
    assert!(
        sh.oh == 0 || sh.ow == 0 || ((sh.oh - 1) * sh.s + sh.k <= sh.hp && (sh.ow - 1) * sh.s + sh.k <= sh.wp),
        "the kernel reaches outside the padded input: {sh:?}"
    );
    // SAFETY: the features are present (asserted above); every read and write is inside the
    // slices, whose lengths are checked against the shape above.
    #[cfg(target_arch = "x86_64")]
    unsafe {
        conv_avx2(xp.as_ptr(), w.as_ptr(), sh, out.as_mut_ptr())
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn conv_avx2(xp: *const f32, w: *const f32, sh: Shape, out: *mut f32) {
    let mut co0 = 0;
    while co0 < sh.c_out {
        // SAFETY: as `conv`'s; each call covers channels co0..co0 + 8 * R < c_out.
        unsafe {
            if sh.c_out - co0 >= 16 {
                rows::<2, 6>(xp, w, sh, co0, out);
                co0 += 16;
            } else {
                rows::<1, 12>(xp, w, sh, co0, out);
                co0 += 8;
            }
        }
    }
}

/// Every output row for channels `co0..co0 + 8 * R`, in blocks of `B` positions, the remainder in
/// blocks of 4, 2 and 1.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn rows<const R: usize, const B: usize>(xp: *const f32, w: *const f32, sh: Shape, co0: usize, out: *mut f32) {
    for oy in 0..sh.oh {
        let mut ox = 0;
        // SAFETY: as `conv`'s; each block covers positions ox..ox + its width <= ow.
        unsafe {
            while ox + B <= sh.ow {
                block::<R, B>(xp, w, sh, co0, oy, ox, out);
                ox += B;
            }
            while ox + 4 <= sh.ow {
                block::<R, 4>(xp, w, sh, co0, oy, ox, out);
                ox += 4;
            }
            while ox + 2 <= sh.ow {
                block::<R, 2>(xp, w, sh, co0, oy, ox, out);
                ox += 2;
            }
            while ox < sh.ow {
                block::<R, 1>(xp, w, sh, co0, oy, ox, out);
                ox += 1;
            }
        }
    }
}

/// Output positions `(oy, ox0..ox0 + B)`, channels `co0..co0 + 8 * R`: `B * R` accumulators in
/// registers over every input channel and kernel offset, then added into the planar output.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn block<const R: usize, const B: usize>(
    xp: *const f32,
    w: *const f32,
    sh: Shape,
    co0: usize,
    oy: usize,
    ox0: usize,
    out: *mut f32,
) {
    let Shape { c_in, hp, wp, k, s, c_out, oh, ow } = sh;
    let mut acc: [[__m256; R]; B] = [[_mm256_setzero_ps(); R]; B];
    let mut wv: [__m256; R] = [_mm256_setzero_ps(); R];
    // SAFETY (all pointer arithmetic below): ci < c_in, oy * s + ky < hp and
    // (ox0 + j) * s + kx < wp (checked in `conv`), so inputs are inside xp; weights at
    // ((ci * k + ky) * k + kx) * c_out + co0 + 8 * r + 8 <= the weights' length; outputs at
    // (co0 + c) * oh * ow + oy * ow + ox0 + j < c_out * oh * ow.
    unsafe {
        for ci in 0..c_in {
            for ky in 0..k {
                let row = xp.add((ci * hp + oy * s + ky) * wp + ox0 * s);
                let wrow = w.add((ci * k + ky) * k * c_out + co0);
                for kx in 0..k {
                    for (r, v) in wv.iter_mut().enumerate() {
                        *v = _mm256_loadu_ps(wrow.add(kx * c_out + 8 * r));
                    }
                    for (j, a) in acc.iter_mut().enumerate() {
                        let x = _mm256_broadcast_ss(&*row.add(j * s + kx));
                        for (ar, &wr) in a.iter_mut().zip(&wv) {
                            *ar = _mm256_fmadd_ps(x, wr, *ar);
                        }
                    }
                }
            }
        }
        let n = oh * ow;
        let mut lanes = [0f32; 16];
        for (j, a) in acc.iter().enumerate() {
            for (r, &ar) in a.iter().enumerate() {
                _mm256_storeu_ps(lanes.as_mut_ptr().add(8 * r), ar);
            }
            let pos = oy * ow + ox0 + j;
            for (c, &v) in lanes.iter().enumerate().take(8 * R) {
                *out.add((co0 + c) * n + pos) += v;
            }
        }
    }
}

/// `x` (`[c, h, w]`) with `p` zeros around each plane, into `xp` (`[c, h + 2p, w + 2p]`).
pub(super) fn pad(x: &[f32], (c, h, w): (usize, usize, usize), p: usize, xp: &mut Vec<f32>) {
    let (hp, wp) = (h + 2 * p, w + 2 * p);
    xp.clear();
    xp.resize(c * hp * wp, 0.0);
    for ch in 0..c {
        for y in 0..h {
            let src = &x[(ch * h + y) * w..][..w];
            xp[(ch * hp + y + p) * wp + p..][..w].copy_from_slice(src);
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The direct convolution equals a plain sum in f64 within float rounding, over kernels,
    /// strides, paddings, channel counts (16s, 8s and both), row widths with remainders, and
    /// dense and mostly empty inputs.
    #[test]
    fn direct_convolution_equals_the_plain_sum() {
        if !available() {
            eprintln!("no AVX2 and FMA here: the direct convolution is not used");
            return;
        }
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        // (c_in, h, w, k, s, p, c_out)
        for (c_in, h, w, k, s, p, c_out) in [
            (40, 20, 27, 7, 2, 3, 16),
            (8, 9, 13, 3, 1, 1, 8),
            (16, 10, 21, 3, 2, 1, 32),
            (12, 8, 23, 1, 2, 0, 24),
            (5, 6, 11, 3, 1, 1, 40),
        ] {
            let mut x: Vec<f32> = (0..c_in * h * w).map(|_| rng.random_range(-1.0..1.0)).collect();
            if c_in % 2 == 0 {
                // mostly empty, as a window's heat map
                x.iter_mut().for_each(|v| *v = if rng.random_bool(0.03) { *v } else { 0.0 });
            }
            let wt: Vec<f32> = (0..c_in * k * k * c_out).map(|_| rng.random_range(-0.5..0.5)).collect();
            let (oh, ow) = ((h + 2 * p - k) / s + 1, (w + 2 * p - k) / s + 1);
            let mut xp = Vec::new();
            pad(&x, (c_in, h, w), p, &mut xp);
            let shape = Shape { c_in, hp: h + 2 * p, wp: w + 2 * p, k, s, c_out, oh, ow };
            let start: Vec<f32> = (0..c_out * oh * ow).map(|i| (i % 7) as f32 * 0.1).collect();
            let mut out = start.clone();
            conv(&xp, &wt, shape, &mut out);
            for co in 0..c_out {
                for oy in 0..oh {
                    for ox in 0..ow {
                        let first = start[(co * oh + oy) * ow + ox] as f64;
                        let (sum, magnitude) =
                            super::super::plain_conv_at(&x, (c_in, h, w), (k, s, p), (oy, ox), |ci, ky, kx| {
                                wt[((ci * k + ky) * k + kx) * c_out + co]
                            });
                        let (want, scale) = (first + sum, first.abs() + magnitude);
                        let got = out[(co * oh + oy) * ow + ox] as f64;
                        assert!(
                            (got - want).abs() <= 1e-6 * scale.max(1.0),
                            "{c_in}x{h}x{w} k{k} s{s} p{p} to {c_out}: channel {co} at ({oy}, {ox}) {got} against {want}"
                        );
                    }
                }
            }
        }
    }

    /// Padding copies each plane inside a border of zeros.
    #[test]
    fn padding_surrounds_each_plane_with_zeros() {
        let x: Vec<f32> = (1..=12).map(|v| v as f32).collect();
        let mut xp = Vec::new();
        pad(&x, (2, 2, 3), 1, &mut xp);
        assert_eq!(xp.len(), 2 * 4 * 5);
        assert_eq!(&xp[..5], &[0.0; 5]);
        assert_eq!(&xp[5..10], &[0.0, 1.0, 2.0, 3.0, 0.0]);
        assert_eq!(&xp[20 + 10..20 + 15], &[0.0, 10.0, 11.0, 12.0, 0.0]);
        assert_eq!(xp.iter().filter(|v| **v != 0.0).count(), 12);
    }
}
