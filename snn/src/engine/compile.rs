//! Compilation: each layer laid out for fan-out (weights transposed so that an input's targets are
//! contiguous, convolution maps per pixel, decay tables).

use super::fanout::ConvTargets;
use super::{Lines, Mode, lines, lines_from};
use crate::error::{Error, Result};
use crate::network::{Layer, Op, PoolKind};
use crate::neuron::{NeuronKind, NeuronParams};

/// A dense layer's outputs summed in registers together by a step's spikes
/// ([`super::fanout::fan_in_spikes`]), and the padding of its weight rows.
pub(super) const DENSE_BLOCK: usize = 16;

/// A linear operation laid out for fan-out.
#[derive(Debug, Clone)]
pub(super) enum Fan {
    /// Weights `[in][stride]`: each input's `n_out` weights, padded with zeros to `stride`, a
    /// multiple of [`DENSE_BLOCK`].
    Dense {
        n_out: usize,
        stride: usize,
        wt: Lines<f32>,
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
        wt: Lines<f32>,
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
pub(super) struct Compiled {
    pub(super) fan: Fan,
    pub(super) n_out: usize,
    pub(super) neurons: Option<NeuronParams>,
    pub(super) bias: Option<Vec<f32>>,
    /// Recurrent weights `[in][out]`.
    pub(super) rec_t: Option<Vec<f32>>,
    /// Per recurrent input, the outputs from its first to its last non-zero weight: a spike
    /// adds (and counts operations) there only. All of them in a trained layer; a member's own
    /// block in a merged ensemble's (`spec::ensemble`), whose other blocks are zero.
    pub(super) rec_span: Vec<(u32, u32)>,
    /// Recurrent bias, added from the stream's step 1 on.
    pub(super) rec_bias: Option<Vec<f32>>,
    /// Stepped: a convolution with neurons and without recurrence whose next layer is a
    /// convolution of 8 or 16 channels leaves a step's spikes in its buckets
    /// (`LayerState::by_channel`), where the next layer's fan-in reads them in the canonical order,
    /// instead of writing them out as canonical indices (set by `Engine::new`).
    pub(super) spikes_in_buckets: bool,
    /// Every neuron is evaluated every step (bias, or a resting level above threshold).
    pub(super) every_step: bool,
    /// A leaky-integrator readout: keep each neuron's highest membrane.
    pub(super) track_max: bool,
    /// Async mode: per-microsecond decay factors.
    pub(super) decay_table: Vec<f32>,
    pub(super) ln_beta_per_us: f64,
}

/// Exact decay of a LIF membrane over `dt_us` towards its resting level.
#[inline]
pub(super) fn decay(c: &Compiled, p: &NeuronParams, v: f32, dt_us: i64) -> f32 {
    let f = match c.decay_table.get(dt_us as usize) {
        Some(&f) => f,
        None => (c.ln_beta_per_us * dt_us as f64).exp() as f32,
    };
    p.v_leak + (v - p.v_leak) * f
}

pub(super) fn compile(l: &Layer, dt_us: i64, mode: Mode) -> Result<Compiled> {
    let n_out = l.op.n_out();
    let fan = match &l.op {
        Op::Dense { n_in, n_out, weight, .. } => {
            let (wt, stride) = crate::network::dense_by_input(*n_in, *n_out, weight, DENSE_BLOCK);
            Fan::Dense { n_out: *n_out, stride, wt: lines_from(&wt) }
        }
        Op::Conv2d { in_shape, out_channels, kernel, stride, padding, weight, .. } => {
            let [ic, h, w] = *in_shape;
            let (oc, kh, kw) = (*out_channels, kernel[0], kernel[1]);
            let mut wt = lines(0.0, ic * kh * kw * oc);
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
            let map =
                ConvTargets::new([ic * h * w, h * w], kh * kw * oc, [out_hw[0] * out_hw[1], oc], offsets, targets);
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
    let rec_span = rec_t
        .as_ref()
        .map(|t| {
            t.chunks(n_out.max(1))
                .map(|row| {
                    let lo = row.iter().position(|&w| w != 0.0).unwrap_or(0);
                    let hi = row.iter().rposition(|&w| w != 0.0).map_or(lo, |h| h + 1);
                    (lo as u32, hi as u32)
                })
                .collect()
        })
        .unwrap_or_default();
    let p = l.neurons;
    let every_step = l.op.bias().is_some() || l.recurrent_bias.is_some() || p.is_some_and(|p| p.v_leak > p.threshold());
    let (mut decay_table, mut ln_beta_per_us) = (Vec::new(), 0.0);
    if mode == Mode::Async
        && let Some(p) = p
    {
        if p.kind == NeuronKind::CubaLif || l.recurrent.is_some() || l.op.bias().is_some() {
            return Err(Error::network(
                "async mode runs LIF and IF layers without bias or recurrence; use stepped mode",
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
        rec_span,
        rec_bias: l.recurrent_bias.clone(),
        spikes_in_buckets: false,
        every_step,
        track_max: p.is_some_and(|p| p.kind == NeuronKind::Li),
        decay_table,
        ln_beta_per_us,
    })
}

/// Output positions `(ky, kx, oy * ow + ox)` that input pixel `(y, x)` of a convolution with
/// kernel `k`, stride `s` and padding `p` reaches, in an output of `out` rows and columns.
#[inline]
pub fn conv_positions(
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

/// The outputs `(c * oh + oy) * ow + ox` that input `i` (C order) of a pooling reaches.
#[inline]
pub fn pool_targets(
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

#[inline]
pub(super) fn bias_index(fan: &Fan, o: usize) -> usize {
    match fan {
        Fan::Conv { out_hw, .. } => o / (out_hw[0] * out_hw[1]),
        _ => o,
    }
}
