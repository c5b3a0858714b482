//! Sliding-window inference on a stream: a network that reads windows of the last `n` steps,
//! queried every step, shares the first layer's synaptic work between overlapping windows.
//!
//! The first layer's input current of a step is linear in that step's input events, so it is
//! computed once per step (each input event touches its fan-out once, as in the event-driven
//! engine) and kept; a window then replays the neurons from rest over its steps' stored currents,
//! and the later layers from the spikes. The result is exactly the time-stepped network's
//! ([`crate::network::forward_dense`]) on the window: same spikes, same readout.
//! A stream queried every step costs one pass of its events through the first layer, not one per
//! window it falls in.

use crate::error::{Error, Result};
use crate::network::{Network, Op};
use crate::neuron::{NeuronKind, Reset};

/// A network prepared for sliding-window inference.
#[derive(Debug, Clone)]
pub struct Sliding {
    net: Network,
    /// Per layer: a dense layer's weights by input, each input's fan-out contiguous and padded
    /// with zeros to a multiple of [`BLOCK`] (`[n_in][stride]`); `None` for other ops (their own
    /// fan-out is used).
    by_input: Vec<Option<ByInput>>,
}

/// Outputs summed together in registers by [`ByInput::sum`].
const BLOCK: usize = 16;
/// Layers wider than this add each input's row to the outputs in memory instead: their rows are
/// read once, front to back (a wide first layer's weights do not fit the caches).
const ROW_WISE_ABOVE: usize = 64;

#[derive(Debug, Clone)]
struct ByInput {
    weight: Vec<f32>,
    stride: usize,
}

impl ByInput {
    fn new(n_in: usize, n_out: usize, weight: &[f32]) -> ByInput {
        let (weight, stride) = crate::network::dense_by_input(n_in, n_out, weight, BLOCK);
        ByInput { weight, stride }
    }

    /// `out[o] = 0 + x_1 w_(i_1, o) + x_2 w_(i_2, o) + ...` over `inputs` in their order: the
    /// same products added in the same order per output as [`Op::accumulate`] input by input,
    /// so the same floats, with [`BLOCK`] outputs held in registers through the inputs instead of
    /// loaded and stored for each (a store and a load per input and output, and, with few
    /// outputs, each add waiting on the last one's store). `inputs` must be inside `0..n_in`.
    fn sum(&self, inputs: &[(u32, f32)], out: &mut [f32]) {
        if out.len() > ROW_WISE_ABOVE {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx") {
                // SAFETY: the CPU has AVX (checked just above).
                unsafe { rows_avx(&self.weight, self.stride, inputs, out) };
                return;
            }
            rows(&self.weight, self.stride, inputs, out);
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY (each arm): the CPU has AVX (checked just above); `stride` is a multiple of
            // `BLOCK` at least `out.len()`, so at most 64 here, and `8 B` of it.
            match self.stride / 8 {
                2 => return unsafe { regs_avx::<2>(&self.weight, self.stride, inputs, out) },
                4 => return unsafe { regs_avx::<4>(&self.weight, self.stride, inputs, out) },
                6 => return unsafe { regs_avx::<6>(&self.weight, self.stride, inputs, out) },
                8 => return unsafe { regs_avx::<8>(&self.weight, self.stride, inputs, out) },
                _ => {}
            }
        }
        for (c, chunk) in out.chunks_mut(BLOCK).enumerate() {
            let mut a = [0f32; BLOCK];
            for &(i, x) in inputs {
                let at = i as usize * self.stride + c * BLOCK;
                let w: &[f32; BLOCK] = self.weight[at..at + BLOCK].try_into().expect("a padded row");
                for (a, w) in a.iter_mut().zip(w) {
                    *a += x * w;
                }
            }
            chunk.copy_from_slice(&a[..chunk.len()]);
        }
    }
}

/// One window's outcome.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WindowOutput {
    /// A leaky-integrator readout: `max(0, highest membrane)` per output; empty otherwise.
    pub v_max: Vec<f32>,
    /// Spikes of the output layer per neuron.
    pub counts: Vec<u32>,
    /// Synaptic operations of the layers after the first (the first layer's are counted when its
    /// currents are made).
    pub synops: u64,
}

/// `out = 0 + x_1 w_(i_1) + x_2 w_(i_2) + ...`, each input's row added to the outputs in memory,
/// front to back.
#[inline(always)]
fn rows(weight: &[f32], stride: usize, inputs: &[(u32, f32)], out: &mut [f32]) {
    out.fill(0.0);
    for &(i, x) in inputs {
        add_row(out, x, &weight[i as usize * stride..][..stride]);
    }
}

/// `out += x row`, output by output.
#[inline(always)]
fn add_row(out: &mut [f32], x: f32, row: &[f32]) {
    for (o, w) in out.iter_mut().zip(row) {
        *o += x * w;
    }
}

/// [`rows`] in AVX registers, eight outputs at a time: the same multiplies and adds per output
/// (no fused multiply-add), so the same floats. The next input's row is asked for while this
/// one is added: a wide layer's rows do not fit the caches, and which row comes next is known.
///
/// # Safety
/// The CPU must have AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn rows_avx(weight: &[f32], stride: usize, inputs: &[(u32, f32)], out: &mut [f32]) {
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
    out.fill(0.0);
    for (k, &(i, x)) in inputs.iter().enumerate() {
        if let Some(&(next, _)) = inputs.get(k + 1) {
            let row = weight.as_ptr().wrapping_add(next as usize * stride);
            // a cache line holds 16 floats; a prefetch never faults, whatever the address
            for line in (0..stride).step_by(16) {
                _mm_prefetch::<_MM_HINT_T0>(row.wrapping_add(line).cast());
            }
        }
        add_row(out, x, &weight[i as usize * stride..][..stride]);
    }
}

/// [`ByInput::sum`]'s outputs all held in `B` AVX registers of eight through the inputs, so
/// that each input's row is read once and its adds are `B` independent chains (the portable
/// code holds [`BLOCK`] outputs at a time, one pass over the inputs each): the same multiplies
/// and adds per output in the same order (no fused multiply-add), so the same floats. Rows are
/// `stride >= 8 B` weights; `out.len() <= 8 B`.
///
/// # Safety
/// The CPU must have AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn regs_avx<const B: usize>(weight: &[f32], stride: usize, inputs: &[(u32, f32)], out: &mut [f32]) {
    use std::arch::x86_64::_mm256_storeu_ps;
    use std::arch::x86_64::{_mm256_add_ps, _mm256_loadu_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps};
    const { assert!(B >= 1 && B <= 8, "at most eight registers") };
    assert!(out.len() <= 8 * B && 8 * B <= stride, "the outputs fit the registers and the rows");
    let mut a = [_mm256_setzero_ps(); B];
    for &(i, x) in inputs {
        let row: &[f32] = &weight[i as usize * stride..][..8 * B];
        let x = _mm256_set1_ps(x);
        for (q, r) in a.iter_mut().enumerate() {
            let w: &[f32; 8] = row[8 * q..8 * q + 8].try_into().expect("eight lanes");
            // SAFETY: `w` is eight readable f32s; unaligned loads are allowed.
            *r = _mm256_add_ps(*r, _mm256_mul_ps(x, unsafe { _mm256_loadu_ps(w.as_ptr()) }));
        }
    }
    let mut padded = [0f32; 64];
    for (q, &r) in a.iter().enumerate() {
        let p: &mut [f32; 8] = (&mut padded[8 * q..8 * q + 8]).try_into().expect("eight lanes");
        // SAFETY: `p` is eight writable f32s; unaligned stores are allowed.
        unsafe { _mm256_storeu_ps(p.as_mut_ptr(), r) };
    }
    let n = out.len();
    out.copy_from_slice(&padded[..n]);
}

impl Sliding {
    /// The first layer must not be recurrent (its current would depend on the past window).
    pub fn new(net: &Network) -> Result<Sliding> {
        net.validate()?;
        if net.layers[0].recurrent.is_some() {
            return Err(Error::network("sliding-window inference needs a first layer without recurrence"));
        }
        let by_input = net
            .layers
            .iter()
            .map(|l| match &l.op {
                Op::Dense { n_in, n_out, weight, .. } => Some(ByInput::new(*n_in, *n_out, weight)),
                _ => None,
            })
            .collect();
        Ok(Sliding { net: net.clone(), by_input })
    }

    /// Layer `k`'s outputs from its active inputs `(input, value)` (ascending): `out` is set to
    /// their weighted sum (the same floats as [`Op::accumulate`] input by input from zero); the
    /// synaptic operations.
    fn sum(&self, k: usize, inputs: &[(u32, f32)], out: &mut [f32]) -> u64 {
        match &self.by_input[k] {
            Some(t) => {
                t.sum(inputs, out);
                (inputs.len() * out.len()) as u64
            }
            None => {
                out.fill(0.0);
                inputs.iter().map(|&(i, x)| self.net.layers[k].op.accumulate(i as usize, x, out) as u64).sum()
            }
        }
    }

    pub fn n_inputs(&self) -> usize {
        self.net.n_inputs()
    }

    /// The first layer's input current of one step from its active inputs `(input, value)` (in
    /// ascending input order, as the time-stepped network sums them), with the bias; the synaptic
    /// operations it took.
    pub fn currents(&self, inputs: &[(u32, f32)], out: &mut Vec<f32>) -> Result<u64> {
        let op = &self.net.layers[0].op;
        out.clear();
        out.resize(op.n_out(), 0.0);
        if let Some(&(i, _)) = inputs.iter().find(|&&(i, _)| i as usize >= self.net.n_inputs()) {
            return Err(Error::input(format!("input {i} outside 0..{}", self.net.n_inputs())));
        }
        let synops = self.sum(0, inputs, out);
        add_bias(op, out);
        Ok(synops)
    }

    /// Runs the network from rest over the steps whose first-layer currents are `steps`.
    pub fn run(&self, steps: &[&[f32]]) -> WindowOutput {
        self.run_with(steps, &mut RunScratch::default())
    }

    /// [`run`](Self::run) reusing `scratch`'s memory between windows.
    pub fn run_with(&self, steps: &[&[f32]], scratch: &mut RunScratch) -> WindowOutput {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above).
            return unsafe { self.run_avx2(steps, scratch) };
        }
        self.run_body(steps, scratch)
    }

    /// [`run_with`](Self::run_with) compiled for AVX2: the neurons' updates eight lanes a
    /// register instead of four (the same operations, no fused multiply-add, so the same floats).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2(&self, steps: &[&[f32]], scratch: &mut RunScratch) -> WindowOutput {
        self.run_body(steps, scratch)
    }

    #[inline(always)]
    fn run_body(&self, steps: &[&[f32]], scratch: &mut RunScratch) -> WindowOutput {
        let layers = &self.net.layers;
        let last = layers.len() - 1;
        let RunScratch { v, cur, x, nz, acc } = scratch;
        v.resize(layers.len(), Vec::new());
        cur.resize(layers.len(), Vec::new());
        for (k, l) in layers.iter().enumerate() {
            v[k].clear();
            v[k].resize(l.op.n_out(), 0.0);
            cur[k].clear();
            cur[k].resize(l.op.n_out(), 0.0);
        }
        let li = layers[last].neurons.is_some_and(|p| p.kind == NeuronKind::Li);
        let mut out = WindowOutput {
            v_max: vec![0.0; if li { layers[last].op.n_out() } else { 0 }],
            counts: vec![0; layers[last].op.n_out()],
            synops: 0,
        };
        for step in steps {
            for (k, layer) in layers.iter().enumerate() {
                let n = layer.op.n_out();
                let input: &[f32] = if k == 0 {
                    step
                } else {
                    acc.clear();
                    acc.resize(n, 0.0);
                    // zero inputs add nothing: summing only the non-zero ones (in ascending
                    // order) gives the same floats
                    out.synops += self.sum(k, nz, acc);
                    add_bias(&layer.op, acc);
                    acc
                };
                match &layer.neurons {
                    None => {
                        x.clear();
                        x.extend_from_slice(input);
                        nz.clear();
                        nz.extend(x.iter().enumerate().filter(|(_, v)| **v != 0.0).map(|(j, &v)| (j as u32, v)));
                    }
                    Some(p) => {
                        x.clear();
                        x.resize(n, 0.0);
                        let (vk, ck) = (&mut v[k], &mut cur[k]);
                        if p.kind == NeuronKind::CubaLif {
                            for j in 0..n {
                                if p.step(&mut ck[j], &mut vk[j], input[j]) {
                                    x[j] = 1.0;
                                }
                            }
                        } else {
                            // `NeuronParams::step` without a synaptic current, its constants
                            // hoisted: the same operations in the same order, and no branch on
                            // the spike (which neurons fire varies, so it would mispredict)
                            let (beta, leak, th) = (p.beta, p.leak_term(), p.threshold());
                            let (subtract, v_reset, v_th) = (p.reset == Reset::Subtract, p.v_reset, p.v_th);
                            for ((vj, &u), f) in vk.iter_mut().zip(input).zip(x.iter_mut()) {
                                let v_new = beta * *vj + leak + u;
                                let spike = v_new > th;
                                let after = if subtract { v_new - v_th } else { v_reset };
                                *vj = if spike { after } else { v_new };
                                *f = if spike { 1.0 } else { 0.0 };
                            }
                        }
                        // the neurons that fired, in ascending order (a separate pass, so that
                        // the update above stays vectorised)
                        list_fired(x, nz);
                        if k == last {
                            for &(j, _) in nz.iter() {
                                out.counts[j as usize] += 1;
                            }
                        }
                        if k == last && li {
                            for (m, &vj) in out.v_max.iter_mut().zip(vk.iter()) {
                                *m = m.max(vj);
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

/// Lanes per mask of [`list_fired`].
const FIRED_CHUNK: usize = 16;

/// The neurons that fired (`x[j] != 0`) as `(j, 1.0)`, ascending. Spikes are sparse, so each
/// [`FIRED_CHUNK`] lanes are compared at once into a mask and only its set bits are walked: one
/// branch a chunk, mostly not taken, where a neuron at a time carried the list's length from
/// each compare to the next.
fn list_fired(x: &[f32], nz: &mut Vec<(u32, f32)>) {
    nz.clear();
    nz.reserve(x.len());
    let mut chunks = x.chunks_exact(FIRED_CHUNK);
    let mut base = 0u32;
    for c in &mut chunks {
        let mut m = nonzero_mask(c.try_into().expect("a whole chunk"));
        while m != 0 {
            nz.push((base + m.trailing_zeros(), 1.0));
            m &= m - 1;
        }
        base += FIRED_CHUNK as u32;
    }
    nz.extend(chunks.remainder().iter().enumerate().filter(|(_, f)| **f != 0.0).map(|(i, _)| (base + i as u32, 1.0)));
}

/// Bit `i` set when `c[i] != 0` (NaN included, as `!=` has it): four SSE compares (part of the
/// x86-64 baseline).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn nonzero_mask(c: &[f32; FIRED_CHUNK]) -> u32 {
    use std::arch::x86_64::{_mm_cmpneq_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_setzero_ps};
    let mut m = 0u32;
    for (q, lanes) in c.chunks_exact(4).enumerate() {
        // SAFETY: SSE is part of x86-64; `lanes` holds four floats.
        let bits = unsafe { _mm_movemask_ps(_mm_cmpneq_ps(_mm_loadu_ps(lanes.as_ptr()), _mm_setzero_ps())) };
        m |= (bits as u32) << (4 * q);
    }
    m
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn nonzero_mask(c: &[f32; FIRED_CHUNK]) -> u32 {
    c.iter().enumerate().fold(0, |m, (i, &f)| m | (u32::from(f != 0.0) << i))
}

/// Memory [`Sliding::run_with`] reuses between windows.
#[derive(Debug, Clone, Default)]
pub struct RunScratch {
    v: Vec<Vec<f32>>,
    cur: Vec<Vec<f32>>,
    /// The last layer's outputs, and the non-zero ones (ascending, with their values).
    x: Vec<f32>,
    nz: Vec<(u32, f32)>,
    acc: Vec<f32>,
}

fn add_bias(op: &Op, acc: &mut [f32]) {
    if let Some(b) = op.bias() {
        let plane = acc.len() / b.len();
        for (j, a) in acc.iter_mut().enumerate() {
            *a += b[j / plane];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::{Layer, forward_dense, random_input};
    use crate::neuron::NeuronParams;
    use rand::{Rng, SeedableRng};

    fn net(seed: u64, li: bool) -> Network {
        net_of(seed, li, 16)
    }

    /// `h` hidden neurons: up to [`ROW_WISE_ABOVE`] their currents are summed in registers,
    /// beyond it row by row.
    fn net_of(seed: u64, li: bool, h: usize) -> Network {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut w = |n: usize, s: f32| (0..n).map(|_| rng.random_range(-s..s)).collect::<Vec<f32>>();
        let (i, o) = (40, 5);
        let l0 = Layer {
            op: Op::Dense { n_in: i, n_out: h, weight: w(i * h, 0.6), bias: Some(w(h, 0.1)) },
            neurons: Some(NeuronParams::lif(0.8)),
            recurrent: None,
            recurrent_bias: None,
        };
        let out = if li { NeuronParams::leaky_integrator(0.9) } else { NeuronParams::lif(0.9) };
        let l1 = Layer {
            op: Op::Dense { n_in: h, n_out: o, weight: w(h * o, 0.8), bias: None },
            neurons: Some(out),
            recurrent: None,
            recurrent_bias: None,
        };
        Network::new(vec![i], vec![l0, l1]).unwrap()
    }

    #[test]
    fn every_window_of_a_stream_equals_the_time_stepped_network() {
        // 16 to 64 hidden neurons: 2, 4, 6 and 8 registers (with AVX) or 16 at a time
        for (li, h) in [(true, 16), (false, 16), (true, 26), (false, 33), (true, 64), (true, 90), (false, 70)] {
            let net = net_of(3, li, h);
            let s = Sliding::new(&net).unwrap();
            let (steps, window) = (60, 12);
            let input = random_input(9, steps, 40, 0.2);
            let currents: Vec<Vec<f32>> = (0..steps)
                .map(|t| {
                    let active: Vec<(u32, f32)> = input[t * 40..(t + 1) * 40]
                        .iter()
                        .enumerate()
                        .filter(|(_, x)| **x != 0.0)
                        .map(|(i, &x)| (i as u32, x))
                        .collect();
                    let mut c = Vec::new();
                    s.currents(&active, &mut c).unwrap();
                    c
                })
                .collect();
            for end in window..=steps {
                let got = s.run(&currents[end - window..end].iter().map(Vec::as_slice).collect::<Vec<_>>());
                let want = forward_dense(&net, &input[(end - window) * 40..end * 40], window).unwrap();
                assert_eq!(got.v_max, want.v_max, "window ending at {end}");
                assert_eq!(got.counts, want.output_counts(5), "window ending at {end}");
            }
        }
    }

    #[test]
    fn the_fired_list_is_every_nonzero_lane_in_order() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut nz = vec![(7, 2.0); 3];
        for n in 0..70 {
            for density in [0.0, 0.05, 0.5, 1.0] {
                let mut x: Vec<f32> = (0..n).map(|_| if rng.random_bool(density) { 1.0 } else { 0.0 }).collect();
                if n > 20 {
                    (x[3], x[17], x[n - 1]) = (f32::NAN, -0.0, 1.0);
                }
                list_fired(&x, &mut nz);
                let want: Vec<(u32, f32)> =
                    x.iter().enumerate().filter(|(_, f)| **f != 0.0).map(|(j, _)| (j as u32, 1.0)).collect();
                assert_eq!(nz, want, "{n} lanes at density {density}");
            }
        }
    }

    #[test]
    fn a_recurrent_first_layer_is_refused() {
        let mut n = net(1, true);
        n.layers[0].recurrent = Some(vec![0.0; 16 * 16]);
        let e = Sliding::new(&n).unwrap_err().to_string();
        assert!(e.contains("without recurrence"), "{e}");
    }
}
