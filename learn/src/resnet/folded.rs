//! The ResNet for inference without burn: batch norm folded into the convolutions at load time,
//! a convolution computed directly where the CPU has AVX2 and FMA (`learn::resnet`'s private
//! `direct` module: the accumulators of a row of outputs in registers, the input read in place)
//! or as a matrix product (im2col in tiles of output rows, then `gemm`, the crate burn's CPU
//! backend calls), or, on a sparse input such as a window's heat map, a scatter of the non-zero
//! inputs into the outputs they reach ([`SPARSE_BELOW_DIRECT`], [`SPARSE_BELOW`]); ReLU and the
//! residual sums fused into the output, scratch buffers reused across calls. The same logits as
//! [`super::Resnet::forward`] in evaluation mode (tested to 1e-5 of the logit, every path).
//!
//! One image runs on the calling thread; [`FoldedResnet::logits_batch`] spreads a batch's images
//! over rayon's threads, and takes each thread's share of them through the last blocks together
//! where those are small in area and wide in channels (ResNet-34's: one product per convolution
//! for the group, so that its weights are read once, not once an image), with the same logits to
//! the bit.

use super::ResnetConfig;
use crate::error::{Error, Result};
use rayon::prelude::*;
use snn::model_file::NamedTensor;
use std::cell::RefCell;

/// burn's `BatchNormConfig` default, which every model here was trained with.
const BN_EPSILON: f32 = 1e-5;

/// A convolution with its batch norm folded in: `weight` is `[c_out][c_in * k * k]`.
#[derive(Debug, Clone)]
struct Conv {
    c_in: usize,
    c_out: usize,
    k: usize,
    stride: usize,
    pad: usize,
    weight: Vec<f32>,
    /// The same weights as `[c_in][k][k][c_out]`: one input's contribution to every output
    /// channel is contiguous, for inputs scattered one by one ([`Conv::forward`] on sparse input).
    weight_by_input: Vec<f32>,
    bias: Vec<f32>,
}

/// Below this share of non-zero inputs a convolution scatters each non-zero input into the
/// outputs it reaches instead of one dense matrix product: the stem's input, a window's heat map,
/// has 2-4% of its cells non-zero, so the scatter does 25-50x fewer multiply-adds. Set where the
/// two measured about equal on the lite shape, each path forced (2026-11-28, one core: the scatter
/// 6.1 / 11.3 / 14.7 ms a window against the product's 9.2 / 12.0 / 13.3 ms at 10 / 20 / 30% of
/// the cells non-zero).
pub const SPARSE_BELOW: f64 = 0.2;

/// [`SPARSE_BELOW`] where the dense convolution is the direct one (the `direct` module, about three
/// times im2col's speed on the lite stem). First set at 3%, where the two measured about equal
/// (2026-11-28, lite, one core, each path forced). Since 2026-11-29 the scatter finds a cell's
/// row without dividing and its non-zero cells without a branch per cell, and the shipped models
/// crop 40 x 40 pooled cells: `braille bench --model M --density D --samples 300 --batch 1
/// --threads 1`, batch 1, one core, the scatter below the threshold and the direct convolution
/// above it, the tiny segmentation network 0.21 / 0.22 / 0.26 ms a window at 4.9 / 5.5 / 5.9%
/// against the direct one's 0.24-0.26 ms at any density, the lite classifier 0.27 / 0.27-0.39 /
/// 0.30-0.33 ms against 0.35-0.36 ms: about equal at 6% for the tiny one, the lite one ahead.
/// Raised to 8% on 2026-12-02, after the scatter was compiled for AVX and for the stems' widths
/// (two runs of the same command at 5-16% non-zero, the scatter timed by the im2col row, whose
/// threshold is 20%: the tiny network about equal at 7-9%, 0.20-0.32 against 0.23-0.29 ms, the
/// direct one ahead from 12%; the lite one 0.24-0.37 against 0.37-0.49 ms at 7-9%, equal at 12%).
pub const SPARSE_BELOW_DIRECT: f64 = 0.08;

/// The most floats of im2col columns made at once (1 MiB; on 2026-11-28's 2-core EPYC the tiny
/// preset's dense stem ran in 1.6 ms a window with it against 2.1 ms with 256 KiB, the lite
/// preset's alike within the machine's noise).
const COL_TILE_FLOATS: usize = 256 * 1024;

/// A block runs on a group of images at once ([`FoldedResnet::logits_batch`]) when its
/// convolutions' outputs are fewer than this many positions an image (and at least two), and
/// their channels more than [`GROUP_ABOVE_CHANNELS`]: there a layer's weights (ResNet-34's last
/// stage: 9.4 MB a convolution) would be read once an image for a product of a few dozen columns.
/// Set on the `paper` preset (2026-12-04, `braille bench --model
/// models/nominal/resnet-paper-normaug.safetensors --batch 32 --threads 2 --density 1`, one call
/// each on a noisy host, ms a window, with [`COL_GROUP_FLOATS`] at 1 MiB): 64 and 128 positions
/// (both the last two stages: the spread is the host's) 14.4 and 15.5, 256 (the last three)
/// 15.1; 16 (the last stage alone) 15.3 with 8 MiB of columns; every block a window at a time
/// 16.0.
const GROUP_BELOW_POSITIONS: usize = 64;

/// The channels a grouped block's convolutions exceed. `gemm` splits a product's inner dimension
/// by the cache's size, except in a product of at most 64 rows and 64 columns (or of one column),
/// which it splits otherwise: with more than 64 output channels an image's product and a group's
/// take the same split, so each output is the same sum in the same order and the group's logits
/// are each image's own to the bit. Narrower layers hold small weights, where grouping gains
/// little.
const GROUP_ABOVE_CHANNELS: usize = 64;

/// The most floats of im2col columns made at once for a group of images (1 MiB, within a core's
/// second-level cache; the same command with 64 positions gave 16.3 ms a window with 8 MiB, 14.9
/// with 2 MiB, and 22.2 with 512 KiB in one call on the noisy host).
const COL_GROUP_FLOATS: usize = 256 * 1024;

/// The output height or width of a convolution or pooling.
fn out_len(n: usize, k: usize, stride: usize, pad: usize) -> usize {
    (n + 2 * pad - k) / stride + 1
}

impl Conv {
    /// `conv` (`[c_out, c_in, k, k]`) followed by batch norm `bn` (evaluation mode).
    fn fold(tensors: &Tensors, conv: &str, bn: &str, stride: usize, pad: usize) -> Result<Conv> {
        let w = tensors.get(&format!("{conv}.weight"))?;
        let [c_out, c_in, k, k2] = w.shape[..] else {
            return Err(tensors.error(&format!("{conv}.weight"), format!("shape {:?}, not 4-D", w.shape)));
        };
        if k != k2 {
            return Err(tensors.error(&format!("{conv}.weight"), format!("kernel {k}x{k2}, not square")));
        }
        let per = |name: &str| -> Result<&[f32]> {
            let t = tensors.get(&format!("{bn}.{name}"))?;
            if t.data.len() != c_out {
                return Err(
                    tensors.error(&format!("{bn}.{name}"), format!("{} values for {c_out} channels", t.data.len()))
                );
            }
            Ok(&t.data)
        };
        let (gamma, beta, mean, var) = (per("gamma")?, per("beta")?, per("running_mean")?, per("running_var")?);
        let fan = c_in * k * k;
        let mut weight = w.data.clone();
        let mut bias = vec![0.0; c_out];
        for o in 0..c_out {
            let scale = gamma[o] / (var[o] + BN_EPSILON).sqrt();
            weight[o * fan..(o + 1) * fan].iter_mut().for_each(|v| *v *= scale);
            bias[o] = beta[o] - mean[o] * scale;
        }
        let mut weight_by_input = vec![0.0; weight.len()];
        for o in 0..c_out {
            for (j, v) in weight[o * fan..(o + 1) * fan].iter().enumerate() {
                weight_by_input[j * c_out + o] = *v;
            }
        }
        Ok(Conv { c_in, c_out, k, stride, pad, weight, weight_by_input, bias })
    }

    /// As [`Conv::forward`] without residual, for a sparse input given as its non-zero cells
    /// `nz` (of `[c_in, h, w]`, in index order, as [`nonzeros`] gives them): each added into
    /// every output it reaches (accumulated as
    /// `[oy][ox][c_out]` in `col`, then laid out as `[c_out][oy][ox]` in `out`).
    fn forward_scatter(
        &self,
        nz: &[(u32, f32)],
        (h, w): (usize, usize),
        out: &mut Vec<f32>,
        col: &mut Vec<f32>,
        relu: bool,
    ) -> (usize, usize) {
        let (k, s, p, co) = (self.k, self.stride, self.pad, self.c_out);
        let (oh, ow) = (out_len(h, k, s, p), out_len(w, k, s, p));
        col.clear();
        for _ in 0..oh * ow {
            col.extend_from_slice(&self.bias);
        }
        let g = Scatter { h, w, k, s, p, co, oh, ow };
        scatter(nz, &self.weight_by_input, g, col);
        out.clear();
        out.resize(co * oh * ow, 0.0);
        for (pos, acc) in col.chunks_exact(co).enumerate() {
            for (o, v) in acc.iter().enumerate() {
                out[o * oh * ow + pos] = if relu { v.max(0.0) } else { *v };
            }
        }
        (oh, ow)
    }

    /// `x` (`[c_in, h, w]`) convolved into `out` (`[c_out, oh, ow]`), plus `residual` when given,
    /// then ReLU when `relu`; `col` and `nz` are scratch. Returns `(oh, ow)`.
    #[allow(clippy::too_many_arguments)]
    fn forward(
        &self,
        x: &[f32],
        (h, w): (usize, usize),
        out: &mut Vec<f32>,
        (col, nz): (&mut Vec<f32>, &mut Vec<(u32, f32)>),
        residual: Option<&[f32]>,
        relu: bool,
        direct: bool,
    ) -> (usize, usize) {
        // `direct`: the network's switch; the layer takes the direct path if it also qualifies
        let (oh, ow) = (out_len(h, self.k, self.stride, self.pad), out_len(w, self.k, self.stride, self.pad));
        let direct = self.takes_direct(w, direct);
        if residual.is_none() && self.k > 1 {
            let len = self.c_in * h * w;
            let below = if direct { SPARSE_BELOW_DIRECT } else { SPARSE_BELOW };
            if nonzeros(&x[..len], (below * len as f64) as usize, nz) {
                return self.forward_scatter(nz, (h, w), out, col, relu);
            }
        }
        self.start_output(out, oh * ow, residual);
        if direct {
            self.convolve_direct(x, (h, w), (oh, ow), out, col);
        } else {
            self.convolve_product(x, (h, w), (oh, ow), out, col);
        }
        if relu {
            out.iter_mut().for_each(|v| *v = v.max(0.0));
        }
        (oh, ow)
    }

    /// Adds the convolution of `x` (`[c_in, h, w]`) into `out` (`[c_out, oh, ow]`) by the direct
    /// convolution, reading a zero-padded copy made in `col`.
    fn convolve_direct(
        &self,
        x: &[f32],
        (h, w): (usize, usize),
        (oh, ow): (usize, usize),
        out: &mut [f32],
        col: &mut Vec<f32>,
    ) {
        let (p, (hp, wp)) = (self.pad, (h + 2 * self.pad, w + 2 * self.pad));
        let xp: &[f32] = if p == 0 {
            &x[..self.c_in * h * w]
        } else {
            super::direct::pad(&x[..self.c_in * h * w], (self.c_in, h, w), p, col);
            col
        };
        let shape =
            super::direct::Shape { c_in: self.c_in, hp, wp, k: self.k, s: self.stride, c_out: self.c_out, oh, ow };
        super::direct::conv(xp, &self.weight_by_input, shape, out);
    }

    /// Adds the convolution of `x` (`[c_in, h, w]`) into `out` (`[c_out, oh, ow]`) as im2col
    /// (in tiles of output rows, in `col`) and one `gemm` product per tile.
    fn convolve_product(
        &self,
        x: &[f32],
        (h, w): (usize, usize),
        (oh, ow): (usize, usize),
        out: &mut [f32],
        col: &mut Vec<f32>,
    ) {
        let n = oh * ow;
        let kk = self.c_in * self.k * self.k;
        let pointwise = self.k == 1 && self.stride == 1 && self.pad == 0;
        // Output rows in tiles whose columns stay in the cache (the stem's whole im2col would be
        // 10 MB a window).
        let rows = if pointwise { oh } else { (COL_TILE_FLOATS / (kk * ow).max(1)).clamp(1, oh) };
        for oy0 in (0..oh).step_by(rows) {
            let oy1 = (oy0 + rows).min(oh);
            let nt = (oy1 - oy0) * ow;
            let (rhs, rhs_rs): (&[f32], usize) = if pointwise {
                (x, n)
            } else {
                if col.len() < kk * nt {
                    col.resize(kk * nt, 0.0);
                }
                im2col(
                    (x, h * w),
                    (self.c_in, h, w),
                    (self.k, self.stride, self.pad),
                    (oy0, oy1, ow),
                    (&mut col[..kk * nt], nt),
                );
                (&col[..kk * nt], nt)
            };
            self.add_product((out, oy0 * ow, n), nt, (rhs, rhs_rs));
        }
    }

    /// `out` (`c_out` rows of `n`) set to `residual` plus the bias, or to the bias alone.
    fn start_output(&self, out: &mut Vec<f32>, n: usize, residual: Option<&[f32]>) {
        out.clear();
        match residual {
            Some(r) => {
                out.extend_from_slice(&r[..self.c_out * n]);
                for (row, b) in out.chunks_exact_mut(n).zip(&self.bias) {
                    row.iter_mut().for_each(|v| *v += b);
                }
            }
            None => {
                for b in &self.bias {
                    out.extend(std::iter::repeat_n(*b, n));
                }
            }
        }
    }

    /// Adds the weights (`c_out x kk`) times `rhs` (`kk x cols`, rows `rhs_rs` apart) into the
    /// `c_out x cols` block of `out` whose first row starts at `at`, rows `out_rs` apart, by one
    /// `gemm` product on this thread.
    fn add_product(&self, (out, at, out_rs): (&mut [f32], usize, usize), cols: usize, (rhs, rhs_rs): (&[f32], usize)) {
        let kk = self.c_in * self.k * self.k;
        if cols == 0 || self.c_out == 0 {
            return;
        }
        assert!(
            cols <= out_rs && at + (self.c_out - 1) * out_rs + cols <= out.len(),
            "the product's destination lies within the output"
        );
        assert!(kk == 0 || (cols <= rhs_rs && (kk - 1) * rhs_rs + cols <= rhs.len()), "its columns within `rhs`");
        // SAFETY: row-major matrices of the sizes given, within the slices (just checked): the
        // weights c_out x kk (`weight.len() == c_out * kk`), `rhs` kk x cols, the destination
        // c_out x cols.
        unsafe {
            gemm::gemm(
                self.c_out,
                cols,
                kk,
                out.as_mut_ptr().add(at),
                1,
                out_rs as isize,
                true,
                self.weight.as_ptr(),
                1,
                kk as isize,
                rhs.as_ptr(),
                1,
                rhs_rs as isize,
                1.0,
                1.0,
                false,
                false,
                false,
                gemm::Parallelism::None,
            );
        }
    }

    /// Whether [`Conv::forward`] on an input of `w` columns takes the direct path (given the
    /// network's switch `direct`).
    fn takes_direct(&self, w: usize, direct: bool) -> bool {
        direct
            && self.c_out.is_multiple_of(8)
            && self.c_out <= super::direct::MAX_CHANNELS
            && out_len(w, self.k, self.stride, self.pad) >= super::direct::MIN_ROW
    }

    /// [`Conv::forward`] of `g` images at once, by im2col and `gemm`: `x` is `[c_in][g][h * w]`
    /// (each channel's planes of the images side by side), `out` and `residual` are
    /// `[c_out][g][oh * ow]`. Each image's columns are made in turn and one product takes as many
    /// images as `col_floats` of columns hold ([`COL_GROUP_FLOATS`] but in tests), so that a
    /// layer's weights are read once for all of them, not once an image. With more than
    /// [`GROUP_ABOVE_CHANNELS`] and at least two positions an image, each output is the sum
    /// [`Conv::forward`] makes by its product, to the bit; else the two agree to float rounding.
    #[allow(clippy::too_many_arguments)]
    fn forward_group(
        &self,
        x: &[f32],
        g: usize,
        (h, w): (usize, usize),
        out: &mut Vec<f32>,
        col: &mut Vec<f32>,
        residual: Option<&[f32]>,
        relu: bool,
        col_floats: usize,
    ) -> (usize, usize) {
        let (oh, ow) = (out_len(h, self.k, self.stride, self.pad), out_len(w, self.k, self.stride, self.pad));
        let (n, hw) = (oh * ow, h * w);
        let gn = g * n;
        self.start_output(out, gn, residual);
        let kk = self.c_in * self.k * self.k;
        let pointwise = self.k == 1 && self.stride == 1 && self.pad == 0;
        let per = (col_floats / (kk * n).max(1)).clamp(1, g.max(1));
        for j0 in (0..g).step_by(per) {
            let j1 = (j0 + per).min(g);
            let cols = (j1 - j0) * n;
            let (rhs, rhs_rs): (&[f32], usize) = if pointwise {
                (&x[j0 * n..], gn)
            } else {
                if col.len() < kk * cols {
                    col.resize(kk * cols, 0.0);
                }
                for j in j0..j1 {
                    im2col(
                        (&x[j * hw..], g * hw),
                        (self.c_in, h, w),
                        (self.k, self.stride, self.pad),
                        (0, oh, ow),
                        (&mut col[(j - j0) * n..kk * cols], cols),
                    );
                }
                (&col[..kk * cols], cols)
            };
            self.add_product((out, j0 * n, gn), cols, (rhs, rhs_rs));
        }
        if relu {
            out.iter_mut().for_each(|v| *v = v.max(0.0));
        }
        (oh, ow)
    }
}

/// `col[(c * k + ky) * k + kx][(oy - oy0) * ow + ox] = x[c][oy * s - p + ky][ox * s - p + kx]`
/// (0 outside) for the output rows `oy0..oy1`; channel `c`'s plane starts at `x[c * x_cs]`, and
/// each row of `col` at `col_rs` past the last (`h * w` and the columns' count for one image; a
/// group's stride for one image's share of [`Conv::forward_group`]'s columns).
fn im2col(
    (x, x_cs): (&[f32], usize),
    (c_in, h, w): (usize, usize, usize),
    (k, s, p): (usize, usize, usize),
    (oy0, oy1, ow): (usize, usize, usize),
    (col, col_rs): (&mut [f32], usize),
) {
    let n = (oy1 - oy0) * ow;
    for c in 0..c_in {
        let plane = &x[c * x_cs..][..h * w];
        for ky in 0..k {
            for kx in 0..k {
                // the outputs whose column falls inside the input: ox * s + kx - p in [0, w)
                let lo = (p.saturating_sub(kx)).div_ceil(s).min(ow);
                let hi = if w + p > kx { ((w + p - kx - 1) / s + 1).min(ow) } else { 0 }.max(lo);
                let row = &mut col[((c * k + ky) * k + kx) * col_rs..][..n];
                for oy in oy0..oy1 {
                    let iy = (oy * s + ky) as isize - p as isize;
                    let dst = &mut row[(oy - oy0) * ow..(oy - oy0 + 1) * ow];
                    if iy < 0 || iy >= h as isize {
                        dst.fill(0.0);
                        continue;
                    }
                    let src = &plane[iy as usize * w..(iy as usize + 1) * w];
                    dst[..lo].fill(0.0);
                    dst[hi..].fill(0.0);
                    let first = lo * s + kx - p;
                    if s == 1 {
                        dst[lo..hi].copy_from_slice(&src[first..first + hi - lo]);
                    } else {
                        for (d, v) in dst[lo..hi].iter_mut().zip(src[first..].iter().step_by(s)) {
                            *d = *v;
                        }
                    }
                }
            }
        }
    }
}

/// A scattered convolution's sizes: the input `h x w`, kernel `k`, stride `s`, padding `p`,
/// `co` output channels of `oh x ow`.
#[derive(Debug, Clone, Copy)]
struct Scatter {
    h: usize,
    w: usize,
    k: usize,
    s: usize,
    p: usize,
    co: usize,
    oh: usize,
    ow: usize,
}

/// Adds each non-zero input `nz` (in index order) times its weights (`[c_in][k][k][co]`) into
/// every output it reaches, in `col` (`[oy][ox][co]`).
fn scatter(nz: &[(u32, f32)], weight_by_input: &[f32], g: Scatter, col: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: this CPU has AVX (just checked).
        return unsafe { scatter_avx(nz, weight_by_input, g, col) };
    }
    scatter_with(nz, weight_by_input, g, col)
}

/// [`scatter`] compiled for AVX: the same multiplies and adds (nothing fused), eight lanes a
/// register instead of four, so the same floats.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn scatter_avx(nz: &[(u32, f32)], weight_by_input: &[f32], g: Scatter, col: &mut [f32]) {
    scatter_with(nz, weight_by_input, g, col)
}

#[inline(always)]
fn scatter_with(nz: &[(u32, f32)], weight_by_input: &[f32], g: Scatter, col: &mut [f32]) {
    // the stems' widths (tiny 8, lite 16) compiled for their width, so each add unrolls
    match g.co {
        8 => scatter_co::<8>(nz, weight_by_input, g, col),
        16 => scatter_co::<16>(nz, weight_by_input, g, col),
        _ => scatter_co::<0>(nz, weight_by_input, g, col),
    }
}

/// [`scatter`] for `CO` output channels, or any number with `CO` 0.
#[inline(always)]
fn scatter_co<const CO: usize>(nz: &[(u32, f32)], weight_by_input: &[f32], g: Scatter, col: &mut [f32]) {
    let Scatter { h, w, k, s, p, oh, ow, .. } = g;
    let co = if CO == 0 { g.co } else { CO };
    // The cells come in index order, so their row (and channel) is found by walking on from
    // the last one's rather than by dividing.
    let (mut c, mut y, mut row_start) = (0usize, 0usize, 0usize);
    for &(i, v) in nz {
        let i = i as usize;
        while i >= row_start + w {
            row_start += w;
            y += 1;
            if y == h {
                (c, y) = (c + 1, 0);
            }
        }
        let (iy, ix) = (y + p, i - row_start + p);
        // outputs oy with oy * s + ky = iy (+ p), ky < k (the stride's division by a constant
        // where it is 1 or 2, the strides these networks have)
        let taps = |n: usize| match s {
            1 => Taps::new(n, k, 1),
            2 => Taps::new(n, k, 2),
            _ => Taps::new(n, k, s),
        };
        for (ky, oy) in taps(iy) {
            if oy >= oh {
                continue;
            }
            for (kx, ox) in taps(ix) {
                if ox >= ow {
                    continue;
                }
                let wrow = &weight_by_input[((c * k + ky) * k + kx) * co..][..co];
                axpy(v, wrow, &mut col[(oy * ow + ox) * co..][..co]);
            }
        }
    }
}

/// The kernel offsets `t < k` with `t ≡ n (mod s)`, `t <= n`, each with its output `(n - t) / s`:
/// the outputs a padded input coordinate `n` reaches.
struct Taps {
    t: usize,
    end: usize,
    s: usize,
    out: usize,
}

impl Taps {
    /// Inlined, so that a constant stride's division and remainder become shifts and masks.
    #[inline(always)]
    fn new(n: usize, k: usize, s: usize) -> Taps {
        let t = n % s;
        Taps { t, end: k.min(n + 1), s, out: (n - t) / s }
    }
}

impl Iterator for Taps {
    type Item = (usize, usize);

    #[inline]
    fn next(&mut self) -> Option<(usize, usize)> {
        if self.t >= self.end {
            return None;
        }
        let item = (self.t, self.out);
        self.t += self.s;
        self.out = self.out.wrapping_sub(1);
        Some(item)
    }
}

/// `y += a * x`, eight lanes at a time (fixed-width chunks, so that the compiler vectorises them).
#[inline(always)]
fn axpy(a: f32, x: &[f32], y: &mut [f32]) {
    let mut ys = y.chunks_exact_mut(8);
    let mut xs = x.chunks_exact(8);
    for (yc, xc) in (&mut ys).zip(&mut xs) {
        let yc: &mut [f32; 8] = yc.try_into().expect("eight");
        let xc: &[f32; 8] = xc.try_into().expect("eight");
        for j in 0..8 {
            yc[j] += a * xc[j];
        }
    }
    for (yv, xv) in ys.into_remainder().iter_mut().zip(xs.remainder()) {
        *yv += a * xv;
    }
}

/// The non-zero cells of `x` as `(index, value)` into `nz`, unless there are `limit` or more
/// (then `false`). Cells are compared eight at once and taken 64 to a mask, and only the non-zero
/// ones visited: a window's heat map has 2-6% of its cells non-zero, scattered, so a branch per
/// cell or per eight cells would often mispredict.
fn nonzeros(x: &[f32], limit: usize, nz: &mut Vec<(u32, f32)>) -> bool {
    nz.clear();
    nz.reserve(limit + 64);
    let chunks = x.chunks_exact(64);
    let mut last = [0.0; 64];
    last[..chunks.remainder().len()].copy_from_slice(chunks.remainder());
    let whole = chunks.map(|c| <&[f32; 64]>::try_from(c).expect("64"));
    for (b, chunk) in whole.chain(std::iter::once(&last)).enumerate() {
        let mut bits = chunk
            .chunks_exact(8)
            .enumerate()
            .fold(0u64, |m, (e, c)| m | u64::from(nonzero_bits(c.try_into().expect("eight"))) << (8 * e));
        if bits == 0 {
            continue;
        }
        while bits != 0 {
            let j = bits.trailing_zeros() as usize;
            nz.push(((b * 64 + j) as u32, chunk[j]));
            bits &= bits - 1;
        }
        if nz.len() >= limit {
            return false;
        }
    }
    true
}

/// Bit `j` set when `chunk[j] != 0.0` (so for NaN, not for either zero).
#[inline(always)]
fn nonzero_bits(chunk: &[f32; 8]) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cmpneq_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_setzero_ps};
        // SAFETY: SSE is part of x86-64's baseline; both loads read four floats inside `chunk`.
        unsafe {
            let zero = _mm_setzero_ps();
            let lo = _mm_movemask_ps(_mm_cmpneq_ps(_mm_loadu_ps(chunk.as_ptr()), zero));
            let hi = _mm_movemask_ps(_mm_cmpneq_ps(_mm_loadu_ps(chunk.as_ptr().add(4)), zero));
            (lo | (hi << 4)) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        chunk.iter().enumerate().fold(0, |m, (j, v)| m | (u32::from(*v != 0.0) << j))
    }
}

/// 3x3 max pooling, stride 2, padding 1 (padding never wins).
fn max_pool(x: &[f32], (c, h, w): (usize, usize, usize), out: &mut Vec<f32>) -> (usize, usize) {
    let (oh, ow) = (out_len(h, 3, 2, 1), out_len(w, 3, 2, 1));
    out.clear();
    out.resize(c * oh * ow, f32::NEG_INFINITY);
    for ch in 0..c {
        let plane = &x[ch * h * w..(ch + 1) * h * w];
        let dst = &mut out[ch * oh * ow..(ch + 1) * oh * ow];
        for oy in 0..oh {
            let (y0, y1) = ((oy * 2).saturating_sub(1), (oy * 2 + 2).min(h));
            for ox in 0..ow {
                let (x0, x1) = ((ox * 2).saturating_sub(1), (ox * 2 + 2).min(w));
                let mut m = f32::NEG_INFINITY;
                for y in y0..y1 {
                    for v in &plane[y * w + x0..y * w + x1] {
                        m = m.max(*v);
                    }
                }
                dst[oy * ow + ox] = m;
            }
        }
    }
    (oh, ow)
}

#[derive(Debug, Clone)]
struct Block {
    conv1: Conv,
    conv2: Conv,
    down: Option<Conv>,
}

/// A fully connected layer: `weight` is `[in][out]`, as burn stores it.
#[derive(Debug, Clone)]
struct Dense {
    n_in: usize,
    n_out: usize,
    weight: Vec<f32>,
    bias: Vec<f32>,
}

/// A model's tensors by name, for lookups that name what is missing.
struct Tensors<'a> {
    all: &'a [NamedTensor],
}

impl<'a> Tensors<'a> {
    fn get(&self, name: &str) -> Result<&'a NamedTensor> {
        self.all.iter().find(|t| t.name == name).ok_or_else(|| self.error(name, "missing".to_string()))
    }
    fn error(&self, name: &str, what: String) -> Error {
        Error::Tensors { tensor: Some(name.to_string()), what }
    }
}

/// Scratch buffers of one thread's forward pass.
#[derive(Default)]
struct Scratch {
    a: Vec<f32>,
    b: Vec<f32>,
    c: Vec<f32>,
    skip: Vec<f32>,
    col: Vec<f32>,
    nz: Vec<(u32, f32)>,
    /// A group's activations (`[c][g][h * w]`): a block's input, its first convolution's output,
    /// its output, and the shortcut ([`FoldedResnet::forward_group`]).
    group: [Vec<f32>; 4],
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// A trained ResNet folded for inference (see the module's documentation). Shared across
/// threads and streams; it holds no state of a call.
#[derive(Debug, Clone)]
pub struct FoldedResnet {
    input: [usize; 3],
    stem: Conv,
    blocks: Vec<Block>,
    fc: Vec<Dense>,
    /// Convolutions computed directly where they qualify (the `direct` module), else by im2col.
    direct: bool,
}

impl FoldedResnet {
    /// The network of `cfg` from a model file's tensors (burn's names, as `learn::resnet::to_tensors`
    /// writes them); a tensor that is missing or of the wrong shape is an error naming it.
    pub fn from_tensors(cfg: &ResnetConfig, tensors: &[NamedTensor]) -> Result<FoldedResnet> {
        let t = Tensors { all: tensors };
        let stem = Conv::fold(&t, "stem", "stem_bn", 2, 3)?;
        let check = |conv: &Conv, name: &str, c_in: usize, c_out: usize, k: usize| {
            if (conv.c_in, conv.c_out, conv.k) != (c_in, c_out, k) {
                return Err(t.error(
                    &format!("{name}.weight"),
                    format!(
                        "{}x{}x{k2}x{k2} where the config has {c_out}x{c_in}x{k}x{k}",
                        conv.c_out,
                        conv.c_in,
                        k2 = conv.k
                    ),
                ));
            }
            Ok(())
        };
        check(&stem, "stem", cfg.input[0], cfg.stem_channels, 7)?;
        let mut blocks = Vec::new();
        let mut c = cfg.stem_channels;
        for (s, &(out, n)) in cfg.stages.iter().enumerate() {
            for b in 0..n {
                let i = blocks.len();
                let stride = if s > 0 && b == 0 { 2 } else { 1 };
                let p = format!("blocks.{i}");
                let conv1 = Conv::fold(&t, &format!("{p}.conv1"), &format!("{p}.bn1"), stride, 1)?;
                check(&conv1, &format!("{p}.conv1"), c, out, 3)?;
                let conv2 = Conv::fold(&t, &format!("{p}.conv2"), &format!("{p}.bn2"), 1, 1)?;
                check(&conv2, &format!("{p}.conv2"), out, out, 3)?;
                let down = if stride != 1 || c != out {
                    let d = Conv::fold(&t, &format!("{p}.down_conv"), &format!("{p}.down_bn"), stride, 0)?;
                    check(&d, &format!("{p}.down_conv"), c, out, 1)?;
                    Some(d)
                } else {
                    None
                };
                blocks.push(Block { conv1, conv2, down });
                c = out;
            }
        }
        let mut fc = Vec::new();
        let mut n_in = c;
        for (k, &n_out) in cfg.hidden.iter().chain(std::iter::once(&cfg.classes)).enumerate() {
            let (wn, bn) = (format!("fc.{k}.weight"), format!("fc.{k}.bias"));
            let (w, b) = (t.get(&wn)?, t.get(&bn)?);
            if w.shape != [n_in, n_out] || b.data.len() != n_out {
                return Err(t.error(
                    &wn,
                    format!("shape {:?} (bias {}), the config says [{n_in}, {n_out}]", w.shape, b.data.len()),
                ));
            }
            fc.push(Dense { n_in, n_out, weight: w.data.clone(), bias: b.data.clone() });
            n_in = n_out;
        }
        let used = 5 + blocks.iter().map(|b| 10 + if b.down.is_some() { 5 } else { 0 }).sum::<usize>() + 2 * fc.len();
        if used != tensors.len() {
            return Err(Error::Tensors {
                tensor: None,
                what: format!("{} tensors where the config uses {used}", tensors.len()),
            });
        }
        Ok(FoldedResnet { input: cfg.input, stem, blocks, fc, direct: super::direct::available() })
    }

    /// The trained burn model `model` of `cfg`, folded.
    #[cfg(feature = "train")]
    pub fn from_model(cfg: &ResnetConfig, model: &super::Resnet) -> Result<FoldedResnet> {
        FoldedResnet::from_tensors(cfg, &super::to_tensors(model)?)
    }

    /// With `on` false, every dense convolution goes through im2col and `gemm`, as on a CPU
    /// without AVX2 and FMA (for comparing the two paths); `true` restores the direct path where
    /// the CPU has it.
    pub fn with_direct_convolution(mut self, on: bool) -> Self {
        self.direct = on && super::direct::available();
        self
    }

    /// Whether the convolutions that qualify are computed directly (AVX2 and FMA present, not
    /// switched off), else all by im2col and `gemm`.
    pub fn direct_convolution(&self) -> bool {
        self.direct
    }

    /// Input `[channels, height, width]`.
    pub fn input_shape(&self) -> [usize; 3] {
        self.input
    }

    /// The logits of one image (`[channels, height, width]`, C order), on this thread.
    pub fn logits(&self, image: &[f32]) -> Result<Vec<f32>> {
        self.check(image)?;
        Ok(SCRATCH.with(|s| self.forward(image, &mut s.borrow_mut())))
    }

    /// The logits of each image, spread over rayon's threads (one image stays on the calling
    /// thread). Where the network's last blocks are small in area and wide in channels (ResNet-34's
    /// `paper` preset), each thread takes a group of the images through those blocks together, a
    /// product per convolution for the whole group (`Conv::forward_group`); the logits are the
    /// same as [`FoldedResnet::logits`] gives each image.
    pub fn logits_batch(&self, images: &[&[f32]]) -> Result<Vec<Vec<f32>>> {
        let from = self.group_from();
        if images.len() < 2 || from == self.blocks.len() {
            return images.par_iter().map(|im| self.logits(im)).collect();
        }
        for im in images {
            self.check(im)?;
        }
        let per = images.len().div_ceil(rayon::current_num_threads().max(1));
        let groups: Vec<Vec<Vec<f32>>> = images
            .par_chunks(per.max(1))
            .map(|group| SCRATCH.with(|s| self.forward_group(group, from, &mut s.borrow_mut())))
            .collect();
        Ok(groups.into_iter().flatten().collect())
    }

    /// An error unless `image` is one input of this network.
    fn check(&self, image: &[f32]) -> Result<()> {
        let [c, h, w] = self.input;
        if image.len() != c * h * w {
            return Err(Error::Tensors {
                tensor: None,
                what: format!("an image of {} values where the network takes {c}x{h}x{w}", image.len()),
            });
        }
        Ok(())
    }

    /// The first block from which on every block runs on a group of images
    /// ([`GROUP_BELOW_POSITIONS`], [`GROUP_ABOVE_CHANNELS`]); the number of blocks when none does.
    fn group_from(&self) -> usize {
        let [_, h, w] = self.input;
        let st = &self.stem;
        let stem = (out_len(h, st.k, st.stride, st.pad), out_len(w, st.k, st.stride, st.pad));
        let (mut h, mut w) = (out_len(stem.0, 3, 2, 1), out_len(stem.1, 3, 2, 1));
        let mut from = self.blocks.len();
        for (i, blk) in self.blocks.iter().enumerate() {
            let c = &blk.conv1;
            let (oh, ow) = (out_len(h, c.k, c.stride, c.pad), out_len(w, c.k, c.stride, c.pad));
            let wide = |c: &Conv, w: usize| c.c_out > GROUP_ABOVE_CHANNELS && !c.takes_direct(w, self.direct);
            let grouped = (2..GROUP_BELOW_POSITIONS).contains(&(oh * ow))
                && wide(c, w)
                && wide(&blk.conv2, ow)
                && blk.down.as_ref().is_none_or(|d| wide(d, w));
            if !grouped {
                from = self.blocks.len();
            } else if from == self.blocks.len() {
                from = i;
            }
            (h, w) = (oh, ow);
        }
        from
    }

    fn forward(&self, image: &[f32], s: &mut Scratch) -> Vec<f32> {
        let (h, w) = self.trunk(image, s, self.blocks.len());
        self.head(&s.a, h * w, 1, 0)
    }

    /// The stem, the pooling and blocks `..upto` on one image; leaves the output in `s.a` and
    /// returns its height and width.
    fn trunk(&self, image: &[f32], s: &mut Scratch, upto: usize) -> (usize, usize) {
        let [_, h, w] = self.input;
        let Scratch { a, b, c, skip, col, nz, .. } = s;
        let (h, w) = self.stem.forward(image, (h, w), b, (col, nz), None, true, self.direct);
        let (mut h, mut w) = max_pool(b, (self.stem.c_out, h, w), a);
        // `a` holds the block's input
        for blk in &self.blocks[..upto] {
            let (h1, w1) = blk.conv1.forward(a, (h, w), b, (col, nz), None, true, self.direct);
            let residual: &[f32] = match &blk.down {
                Some(d) => {
                    d.forward(a, (h, w), skip, (col, nz), None, false, self.direct);
                    skip
                }
                None => a,
            };
            blk.conv2.forward(b, (h1, w1), c, (col, nz), Some(residual), true, self.direct);
            std::mem::swap(a, c);
            (h, w) = (h1, w1);
        }
        (h, w)
    }

    /// `images` each through the blocks before `from` alone, then through the rest together
    /// ([`Conv::forward_group`]); their logits.
    fn forward_group(&self, images: &[&[f32]], from: usize, s: &mut Scratch) -> Vec<Vec<f32>> {
        let g = images.len();
        if g < 2 {
            return images.iter().map(|im| self.forward(im, s)).collect();
        }
        // each image's output of block `from - 1` into the group's layout, `[c][g][h * w]`
        let ch = from.checked_sub(1).map_or(self.stem.c_out, |i| self.blocks[i].conv2.c_out);
        let (mut h, mut w) = (0, 0);
        for (j, im) in images.iter().enumerate() {
            (h, w) = self.trunk(im, s, from);
            let n = h * w;
            if j == 0 {
                s.group[0].clear();
                s.group[0].resize(ch * g * n, 0.0);
            }
            for c in 0..ch {
                s.group[0][(c * g + j) * n..][..n].copy_from_slice(&s.a[c * n..][..n]);
            }
        }
        let [a, b, c, skip] = &mut s.group;
        let col = &mut s.col;
        for blk in &self.blocks[from..] {
            let (h1, w1) = blk.conv1.forward_group(a, g, (h, w), b, col, None, true, COL_GROUP_FLOATS);
            let residual: &[f32] = match &blk.down {
                Some(d) => {
                    d.forward_group(a, g, (h, w), skip, col, None, false, COL_GROUP_FLOATS);
                    skip
                }
                None => a,
            };
            blk.conv2.forward_group(b, g, (h1, w1), c, col, Some(residual), true, COL_GROUP_FLOATS);
            std::mem::swap(a, c);
            (h, w) = (h1, w1);
        }
        (0..g).map(|j| self.head(a, h * w, g, j)).collect()
    }

    /// The global average pooling and the fully connected layers of image `j` of the `g` whose
    /// last block's output `a` holds (`[c][g][n]`).
    fn head(&self, a: &[f32], n: usize, g: usize, j: usize) -> Vec<f32> {
        let ch = self.blocks.last().map_or(self.stem.c_out, |b| b.conv2.c_out);
        let hw = n as f32;
        let mut x: Vec<f32> = (0..ch).map(|c| a[(c * g + j) * n..][..n].iter().sum::<f32>() / hw).collect();
        let last = self.fc.len() - 1;
        for (k, l) in self.fc.iter().enumerate() {
            let mut y = l.bias.clone();
            for (i, &xi) in x.iter().enumerate().take(l.n_in) {
                if xi != 0.0 {
                    let row = &l.weight[i * l.n_out..(i + 1) * l.n_out];
                    y.iter_mut().zip(row).for_each(|(o, wv)| *o += xi * wv);
                }
            }
            if k < last {
                y.iter_mut().for_each(|v| *v = v.max(0.0));
            }
            x = y;
        }
        x
    }
}

#[cfg(all(test, feature = "train"))]
mod tests {
    use super::*;
    use burn::tensor::Device;
    use rand::{Rng, SeedableRng};

    /// A model with trained-looking batch norms (running statistics away from 0 and 1), so the
    /// folding is tested, not only the convolutions.
    fn model(cfg: &ResnetConfig, seed: u64) -> super::super::Resnet {
        let m = cfg.init(&Device::flex());
        let mut tensors = super::super::to_tensors(&m).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        for t in &mut tensors {
            let stat = t.name.rsplit('.').next().unwrap_or_default();
            for v in &mut t.data {
                *v = match stat {
                    "running_var" => rng.random_range(0.2..3.0),
                    "running_mean" | "beta" | "bias" => rng.random_range(-0.5..0.5),
                    "gamma" => rng.random_range(0.5..1.5),
                    _ => *v,
                };
            }
        }
        super::super::from_tensors(cfg, &tensors).unwrap()
    }

    /// `n` images with `density` of their cells non-zero.
    fn images(shape: [usize; 3], n: usize, density: f64, seed: u64) -> Vec<Vec<f32>> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let size = shape.iter().product();
        (0..n)
            .map(|_| {
                (0..size).map(|_| if rng.random_bool(density) { rng.random_range(0.0..3.0) } else { 0.0 }).collect()
            })
            .collect()
    }

    /// Every way of convolving (the scatter of sparse inputs; the direct convolution; im2col and
    /// the product, in one tile of output rows or several) and every shape of block.
    #[test]
    fn folded_logits_equal_burns() {
        for (cfg, seed) in [
            (ResnetConfig::lite([6, 20, 24], 26), 1),
            (ResnetConfig::tiny([4, 17, 13], 2), 2),
            (ResnetConfig { stages: vec![(8, 2), (16, 2), (24, 1)], ..ResnetConfig::lite([3, 33, 29], 5) }, 3),
            // a stem whose im2col takes several tiles of output rows (32 rows, 27 a tile)
            (ResnetConfig::tiny([8, 64, 48], 3), 4),
            // 64 channels direct (10x9), then 72 at 5x5: grouped in a batch
            (ResnetConfig { stages: vec![(64, 1), (72, 1)], ..ResnetConfig::lite([3, 40, 36], 4) }, 5),
        ] {
            let m = model(&cfg, seed);
            let f = FoldedResnet::from_model(&cfg, &m).unwrap();
            // a window's sparsity (the stem scatters) and a dense input (the stem's product)
            let mut ims = images(cfg.input, 3, 0.01, seed + 10);
            ims.extend(images(cfg.input, 3, 0.6, seed + 20));
            let want = super::super::logits(&m, cfg.input, &ims.iter().map(Vec::as_slice).collect::<Vec<_>>());
            // the direct convolutions where the CPU has them, and im2col everywhere
            for direct in [true, false] {
                let f = f.clone().with_direct_convolution(direct);
                let got = f.logits_batch(&ims.iter().map(Vec::as_slice).collect::<Vec<_>>()).unwrap();
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!(g.len(), cfg.classes);
                    for (a, b) in g.iter().zip(w) {
                        assert!(
                            (a - b).abs() <= 1e-5 * (1.0 + b.abs()),
                            "{cfg:?}, direct {}: {a} against burn's {b}",
                            f.direct_convolution()
                        );
                    }
                }
            }
        }
    }

    /// A batch through the grouped blocks gives each image the logits it gets alone, to the bit:
    /// groups of 2 to 7 images (batches spread over 1 to 3 threads), blocks with and without a
    /// shortcut convolution, a pointwise shortcut at stride 1 among them, with the direct
    /// convolutions before the grouped blocks and without, and every block grouped.
    #[test]
    fn grouped_blocks_give_each_image_its_own_logits() {
        // 10x9, then 5x5 and 3x3 positions grouped (72 and 80 channels: the products' inner
        // dimension up to 720, split by `gemm`; a group's product of up to 175 columns)
        let wide = ResnetConfig {
            stem_channels: 8,
            stages: vec![(8, 1), (72, 2), (80, 1)],
            ..ResnetConfig::lite([3, 40, 36], 7)
        };
        // every block grouped (4x4 and 2x2 positions), the first one's shortcut pointwise
        let all =
            ResnetConfig { stem_channels: 8, stages: vec![(72, 1), (96, 1)], ..ResnetConfig::tiny([3, 16, 16], 5) };
        // 16 and 32 channels: no block grouped, as gemm would split their products otherwise
        let narrow = ResnetConfig::lite([6, 20, 24], 26);
        let f = FoldedResnet::from_model(&narrow, &model(&narrow, 4)).unwrap().with_direct_convolution(false);
        assert_eq!(f.group_from(), f.blocks.len());
        for (cfg, seed) in [(wide, 5), (all, 6)] {
            let m = model(&cfg, seed);
            let base = FoldedResnet::from_model(&cfg, &m).unwrap();
            let mut ims = images(cfg.input, 4, 0.02, seed + 10);
            ims.extend(images(cfg.input, 3, 0.7, seed + 20));
            let refs: Vec<&[f32]> = ims.iter().map(Vec::as_slice).collect();
            for direct in [true, false] {
                let f = base.clone().with_direct_convolution(direct);
                assert!(f.group_from() < f.blocks.len(), "{cfg:?}: the test needs grouped blocks");
                let alone: Vec<Vec<f32>> = refs.iter().map(|im| f.logits(im).unwrap()).collect();
                for threads in 1..=3 {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    for n in [2, 5, 7] {
                        let got = pool.install(|| f.logits_batch(&refs[..n])).unwrap();
                        for (g, a) in got.iter().zip(&alone) {
                            let (g, a): (Vec<u32>, Vec<u32>) =
                                (g.iter().map(|v| v.to_bits()).collect(), a.iter().map(|v| v.to_bits()).collect());
                            assert_eq!(g, a, "{cfg:?}, direct {direct}, {threads} threads, batch {n}");
                        }
                    }
                }
            }
        }
    }

    /// A group's columns in several products (one image's, two images', three) give the same
    /// outputs as in one product, with and without a residual; and a pointwise convolution's.
    #[test]
    fn grouped_columns_in_tiles_equal_one_product() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut conv = |c_in: usize, c_out: usize, k: usize, stride: usize, pad: usize| {
            let weight: Vec<f32> = (0..c_out * c_in * k * k).map(|_| rng.random_range(-1.0..1.0)).collect();
            let bias: Vec<f32> = (0..c_out).map(|_| rng.random_range(-0.5..0.5)).collect();
            Conv { c_in, c_out, k, stride, pad, weight_by_input: Vec::new(), weight, bias }
        };
        let (g, (h, w)) = (5, (7, 6));
        for c in [conv(6, 16, 3, 1, 1), conv(6, 24, 3, 2, 1), conv(6, 8, 1, 1, 0), conv(6, 8, 1, 2, 0)] {
            let x: Vec<f32> = (0..c.c_in * g * h * w).map(|k| ((k * 37 % 101) as f32 - 50.0) / 25.0).collect();
            let (oh, ow) = (out_len(h, c.k, c.stride, c.pad), out_len(w, c.k, c.stride, c.pad));
            let r: Vec<f32> = (0..c.c_out * g * oh * ow).map(|k| (k % 13) as f32 / 7.0 - 1.0).collect();
            for residual in [None, Some(r.as_slice())] {
                let (mut whole, mut col) = (Vec::new(), Vec::new());
                c.forward_group(&x, g, (h, w), &mut whole, &mut col, residual, true, usize::MAX);
                let one = c.c_in * c.k * c.k * oh * ow;
                for images in 1..=3 {
                    let mut tiled = Vec::new();
                    c.forward_group(&x, g, (h, w), &mut tiled, &mut col, residual, true, images * one);
                    assert_eq!(whole, tiled, "{images} images a product, k {}, stride {}", c.k, c.stride);
                }
            }
        }
    }

    /// The non-zero cells are those a plain filter keeps (NaN kept, either zero dropped), for
    /// lengths with and without a partial last chunk, or refused once as many as the limit.
    #[test]
    fn the_nonzero_cells_are_the_plain_filters() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let mut nz = Vec::new();
        for len in 0..70 {
            for density in [0.0, 0.05, 0.3, 1.0] {
                let x: Vec<f32> = (0..len)
                    .map(|_| match rng.random_range(0..8) {
                        _ if !rng.random_bool(density) => [0.0, -0.0][rng.random_range(0..2)],
                        0 => f32::NAN,
                        _ => rng.random_range(-2.0..2.0),
                    })
                    .collect();
                let want: Vec<(u32, u32)> =
                    x.iter().enumerate().filter(|(_, v)| **v != 0.0).map(|(i, v)| (i as u32, v.to_bits())).collect();
                for limit in [0, want.len().saturating_sub(1), want.len(), want.len() + 1, len + 8] {
                    let kept = nonzeros(&x, limit, &mut nz);
                    assert_eq!(kept, want.is_empty() || want.len() < limit, "{len} cells, limit {limit}");
                    if kept {
                        let got: Vec<(u32, u32)> = nz.iter().map(|(i, v)| (*i, v.to_bits())).collect();
                        assert_eq!(got, want, "{len} cells, limit {limit}");
                    }
                }
            }
        }
    }

    /// The scatter equals a plain sum for strides 1, 2 and 3 (the constant and the general tap
    /// walks), paddings and kernels, on inputs with empty rows and empty channels between the
    /// non-zero cells (the row walk), at the widths compiled apart (8, 16) and another (12), and finds
    /// the same non-zero cells as a filter.
    #[test]
    fn the_scatter_is_the_plain_convolution() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        // (c_in, h, w, k, s, p, c_out)
        for (c_in, h, w, k, s, p, c_out) in [
            (3, 9, 11, 7, 2, 3, 8),
            (4, 6, 5, 3, 1, 1, 16),
            (2, 10, 13, 5, 3, 2, 8),
            (5, 4, 7, 1, 2, 0, 8),
            (3, 7, 9, 3, 2, 1, 12),
        ] {
            let fan = c_in * k * k;
            let weight: Vec<f32> = (0..c_out * fan).map(|_| rng.random_range(-1.0..1.0)).collect();
            let bias: Vec<f32> = (0..c_out).map(|_| rng.random_range(-1.0..1.0)).collect();
            let mut weight_by_input = vec![0.0; weight.len()];
            for o in 0..c_out {
                for j in 0..fan {
                    weight_by_input[j * c_out + o] = weight[o * fan + j];
                }
            }
            let conv = Conv { c_in, c_out, k, stride: s, pad: p, weight, weight_by_input, bias };
            // channel 1 empty, and every third row of the others
            let x: Vec<f32> = (0..c_in * h * w)
                .map(|i| {
                    let (c, y) = (i / (h * w), i / w % h);
                    if c == 1 || y % 3 == 2 || !rng.random_bool(0.3) { 0.0 } else { rng.random_range(-2.0..2.0) }
                })
                .collect();
            let mut nz = Vec::new();
            assert!(nonzeros(&x, x.len(), &mut nz));
            let want_nz: Vec<(u32, f32)> =
                x.iter().enumerate().filter(|(_, v)| **v != 0.0).map(|(i, v)| (i as u32, *v)).collect();
            assert_eq!(nz, want_nz);
            assert!(!nonzeros(&x, want_nz.len(), &mut nz), "as many as the limit: refused");
            let (mut out, mut col) = (Vec::new(), Vec::new());
            let (oh, ow) = conv.forward_scatter(&want_nz, (h, w), &mut out, &mut col, false);
            for co in 0..c_out {
                for oy in 0..oh {
                    for ox in 0..ow {
                        let (sum, _) =
                            super::super::plain_conv_at(&x, (c_in, h, w), (k, s, p), (oy, ox), |ci, ky, kx| {
                                conv.weight[co * fan + (ci * k + ky) * k + kx]
                            });
                        let want = conv.bias[co] as f64 + sum;
                        let got = out[(co * oh + oy) * ow + ox] as f64;
                        assert!((got - want).abs() <= 1e-5 * (1.0 + want.abs()), "k{k} s{s}: {got} against {want}");
                    }
                }
            }
        }
    }

    #[test]
    fn wrong_tensors_are_named() {
        let cfg = ResnetConfig::tiny([4, 16, 16], 2);
        let mut t = super::super::to_tensors(&cfg.init(&Device::flex())).unwrap();
        t.retain(|t| t.name != "blocks.1.down_bn.running_var");
        let e = FoldedResnet::from_tensors(&cfg, &t).unwrap_err().to_string();
        assert!(e.contains("blocks.1.down_bn.running_var") && e.contains("missing"), "{e}");
        let other = ResnetConfig::tiny([5, 16, 16], 2);
        let t = super::super::to_tensors(&cfg.init(&Device::flex())).unwrap();
        let e = FoldedResnet::from_tensors(&other, &t).unwrap_err().to_string();
        assert!(e.contains("stem.weight"), "{e}");
        let f = FoldedResnet::from_tensors(&cfg, &t).unwrap();
        assert!(f.logits(&[0.0; 3]).unwrap_err().to_string().contains("4x16x16"));
    }
}
