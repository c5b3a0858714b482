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
    /// Per layer: a dense layer's weights by input (`[n_in][n_out]`), so an input's fan-out is
    /// contiguous; `None` for other ops (their own fan-out is used).
    by_input: Vec<Option<Vec<f32>>>,
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
                Op::Dense { n_in, n_out, weight, .. } => {
                    let mut t = vec![0f32; weight.len()];
                    for o in 0..*n_out {
                        for i in 0..*n_in {
                            t[i * n_out + o] = weight[o * n_in + i];
                        }
                    }
                    Some(t)
                }
                _ => None,
            })
            .collect();
        Ok(Sliding { net: net.clone(), by_input })
    }

    /// Adds input `i`'s contribution to layer `k`'s outputs (the same products and order per
    /// output as [`Op::accumulate`]); the synaptic operations.
    #[inline]
    fn accumulate(&self, k: usize, i: usize, x: f32, out: &mut [f32]) -> u64 {
        match &self.by_input[k] {
            Some(t) => {
                let n = out.len();
                for (o, w) in out.iter_mut().zip(&t[i * n..(i + 1) * n]) {
                    *o += x * w;
                }
                n as u64
            }
            None => self.net.layers[k].op.accumulate(i, x, out) as u64,
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
        let mut synops = 0u64;
        for &(i, x) in inputs {
            if i as usize >= self.net.n_inputs() {
                return Err(Error::input(format!("input {i} outside 0..{}", self.net.n_inputs())));
            }
            synops += self.accumulate(0, i as usize, x, out);
        }
        add_bias(op, out);
        Ok(synops)
    }

    /// Runs the network from rest over the steps whose first-layer currents are `steps`.
    pub fn run(&self, steps: &[&[f32]]) -> WindowOutput {
        self.run_with(steps, &mut RunScratch::default())
    }

    /// [`run`](Self::run) reusing `scratch`'s memory between windows.
    pub fn run_with(&self, steps: &[&[f32]], scratch: &mut RunScratch) -> WindowOutput {
        let layers = &self.net.layers;
        let last = layers.len() - 1;
        let RunScratch { v, cur, x, acc } = scratch;
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
                    // zero inputs add nothing: summing only the non-zero ones gives the same floats
                    for (i, &xi) in x.iter().enumerate() {
                        if xi != 0.0 {
                            out.synops += self.accumulate(k, i, xi, acc);
                        }
                    }
                    add_bias(&layer.op, acc);
                    acc
                };
                match &layer.neurons {
                    None => {
                        let next = input.to_vec();
                        *x = next;
                    }
                    Some(p) => {
                        let mut fired = std::mem::take(x);
                        fired.clear();
                        fired.resize(n, 0.0);
                        let (vk, ck) = (&mut v[k], &mut cur[k]);
                        if p.kind == NeuronKind::CubaLif {
                            for j in 0..n {
                                if p.step(&mut ck[j], &mut vk[j], input[j]) {
                                    fired[j] = 1.0;
                                }
                            }
                        } else {
                            // `NeuronParams::step` without a synaptic current, its constants
                            // hoisted: the same operations in the same order, and no branch on
                            // the spike (which neurons fire varies, so it would mispredict)
                            let (beta, leak, th) = (p.beta, p.leak_term(), p.threshold());
                            let (subtract, v_reset, v_th) = (p.reset == Reset::Subtract, p.v_reset, p.v_th);
                            for ((vj, &u), f) in vk.iter_mut().zip(input).zip(fired.iter_mut()) {
                                let v_new = beta * *vj + leak + u;
                                let spike = v_new > th;
                                let after = if subtract { v_new - v_th } else { v_reset };
                                *vj = if spike { after } else { v_new };
                                *f = if spike { 1.0 } else { 0.0 };
                            }
                        }
                        if k == last {
                            for (c, &f) in out.counts.iter_mut().zip(&fired) {
                                *c += (f != 0.0) as u32;
                            }
                        }
                        if k == last && li {
                            for (m, &vj) in out.v_max.iter_mut().zip(vk.iter()) {
                                *m = m.max(vj);
                            }
                        }
                        *x = fired;
                    }
                }
            }
        }
        out
    }
}

/// Memory [`Sliding::run_with`] reuses between windows.
#[derive(Debug, Clone, Default)]
pub struct RunScratch {
    v: Vec<Vec<f32>>,
    cur: Vec<Vec<f32>>,
    x: Vec<f32>,
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
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut w = |n: usize, s: f32| (0..n).map(|_| rng.random_range(-s..s)).collect::<Vec<f32>>();
        let (i, h, o) = (40, 16, 5);
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
        for li in [true, false] {
            let net = net(3, li);
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
    fn a_recurrent_first_layer_is_refused() {
        let mut n = net(1, true);
        n.layers[0].recurrent = Some(vec![0.0; 16 * 16]);
        let e = Sliding::new(&n).unwrap_err().to_string();
        assert!(e.contains("without recurrence"), "{e}");
    }
}
