//! A network's architecture without its weights: what a trainer builds and what a model file
//! records, so that a model can be rebuilt, checked against its weights and run by the engine.

use crate::error::{Error, Result};
use crate::network::{Layer, Network, Op, PoolKind};
use crate::neuron::{NeuronKind, NeuronParams};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// A linear operation, by shape only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "op")]
pub enum OpSpec {
    /// Fully connected to `n_out` (the input is flattened in C order).
    Dense {
        n_out: usize,
    },
    Conv2d {
        out_channels: usize,
        kernel: [usize; 2],
        stride: [usize; 2],
        padding: [usize; 2],
    },
    Pool {
        kind: PoolKind,
        kernel: [usize; 2],
        stride: [usize; 2],
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LayerSpec {
    pub op: OpSpec,
    /// Neurons after the op; `None` passes the op's values on.
    pub neurons: Option<NeuronParams>,
    pub recurrent: bool,
    pub bias: bool,
    /// A bias on the recurrent connection (imported NIR graphs; not trained here).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub recurrent_bias: bool,
}

/// The architecture of a [`Network`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NetworkSpec {
    pub input_shape: Vec<usize>,
    pub layers: Vec<LayerSpec>,
}

/// The trainable tensors of one layer, by shape (empty when absent), in the layouts of
/// [`Network`]: dense `[out, in]`, convolution `[out, in, kh, kw]`, recurrent `[n, n]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayerShapes {
    pub weight: Vec<usize>,
    pub bias: Vec<usize>,
    pub recurrent: Vec<usize>,
    pub recurrent_bias: Vec<usize>,
    /// The layer's input shape (`[n]` or `[c, h, w]`).
    pub input: Vec<usize>,
    pub output: Vec<usize>,
}

/// One layer's weights, flat, in the layouts of [`LayerShapes`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LayerWeights {
    pub weight: Vec<f32>,
    pub bias: Option<Vec<f32>>,
    pub recurrent: Option<Vec<f32>>,
    pub recurrent_bias: Option<Vec<f32>>,
}

impl NetworkSpec {
    /// The tensor shapes of every layer; fails when an op does not fit its input.
    pub fn shapes(&self) -> Result<Vec<LayerShapes>> {
        if self.layers.is_empty() || self.input_shape.is_empty() || self.input_shape.contains(&0) {
            return Err(Error::network(format!(
                "a network needs layers and a non-empty input shape, got {:?}",
                self.input_shape
            )));
        }
        let mut shape = self.input_shape.clone();
        let mut out = Vec::with_capacity(self.layers.len());
        for (k, l) in self.layers.iter().enumerate() {
            let bad = |m: String| Error::layer(k, m);
            let chw = |shape: &[usize]| -> Result<[usize; 3]> {
                match *shape {
                    [c, h, w] => Ok([c, h, w]),
                    _ => Err(bad(format!("needs a [channels, height, width] input, got {shape:?}"))),
                }
            };
            let n_in: usize = shape.iter().product();
            let (weight, output) = match l.op {
                OpSpec::Dense { n_out } => (vec![n_out, n_in], vec![n_out]),
                OpSpec::Conv2d { out_channels, kernel, stride, padding } => {
                    let [c, h, w] = chw(&shape)?;
                    if stride.contains(&0)
                        || kernel.contains(&0)
                        || h + 2 * padding[0] < kernel[0]
                        || w + 2 * padding[1] < kernel[1]
                    {
                        return Err(bad(format!("conv kernel {kernel:?} stride {stride:?} does not fit {shape:?}")));
                    }
                    let o = |d: usize, n: usize| (n + 2 * padding[d] - kernel[d]) / stride[d] + 1;
                    (vec![out_channels, c, kernel[0], kernel[1]], vec![out_channels, o(0, h), o(1, w)])
                }
                OpSpec::Pool { kernel, stride, .. } => {
                    let [c, h, w] = chw(&shape)?;
                    if stride.contains(&0) || kernel.contains(&0) || h < kernel[0] || w < kernel[1] {
                        return Err(bad(format!("pool kernel {kernel:?} stride {stride:?} does not fit {shape:?}")));
                    }
                    let o = |d: usize, n: usize| (n - kernel[d]) / stride[d] + 1;
                    (Vec::new(), vec![c, o(0, h), o(1, w)])
                }
            };
            let n_out: usize = output.iter().product();
            let trainable = !matches!(l.op, OpSpec::Pool { .. });
            if l.bias && !trainable {
                return Err(bad("a pooling layer has no bias".into()));
            }
            if l.recurrent && l.neurons.is_none() {
                return Err(bad("a recurrent connection needs neurons".into()));
            }
            if l.recurrent_bias && !l.recurrent {
                return Err(bad("a recurrent bias needs a recurrent connection".into()));
            }
            out.push(LayerShapes {
                weight,
                bias: if l.bias { vec![output[0]] } else { Vec::new() },
                recurrent: if l.recurrent { vec![n_out, n_out] } else { Vec::new() },
                recurrent_bias: if l.recurrent_bias { vec![n_out] } else { Vec::new() },
                input: std::mem::replace(&mut shape, output.clone()),
                output,
            });
        }
        Ok(out)
    }

    /// The network with these weights (checked against the shapes).
    pub fn build(&self, weights: Vec<LayerWeights>) -> Result<Network> {
        let shapes = self.shapes()?;
        if weights.len() != shapes.len() {
            return Err(Error::network(format!("{} layers of weights for {} layers", weights.len(), shapes.len())));
        }
        let mut layers = Vec::with_capacity(shapes.len());
        for (k, ((l, s), w)) in self.layers.iter().zip(&shapes).zip(weights).enumerate() {
            let check = |name: &str, want: &[usize], got: Option<&Vec<f32>>| -> Result<()> {
                let n: usize = if want.is_empty() { 0 } else { want.iter().product() };
                let len = got.map_or(0, Vec::len);
                if len != n || (want.is_empty() != got.is_none()) {
                    return Err(Error::layer(k, format!("{name} has {len} values, its shape {want:?} needs {n}")));
                }
                Ok(())
            };
            let weight = (!s.weight.is_empty()).then_some(w.weight);
            check("weight", &s.weight, weight.as_ref())?;
            check("bias", &s.bias, w.bias.as_ref())?;
            check("recurrent", &s.recurrent, w.recurrent.as_ref())?;
            check("recurrent bias", &s.recurrent_bias, w.recurrent_bias.as_ref())?;
            let in_shape = || [s.input[0], s.input[1], s.input[2]];
            let op = match l.op {
                OpSpec::Dense { n_out } => Op::Dense {
                    n_in: s.input.iter().product(),
                    n_out,
                    weight: weight.unwrap_or_default(),
                    bias: w.bias,
                },
                OpSpec::Conv2d { out_channels, kernel, stride, padding } => Op::Conv2d {
                    in_shape: in_shape(),
                    out_channels,
                    kernel,
                    stride,
                    padding,
                    weight: weight.unwrap_or_default(),
                    bias: w.bias,
                },
                OpSpec::Pool { kind, kernel, stride } => Op::Pool { kind, in_shape: in_shape(), kernel, stride },
            };
            layers.push(Layer { op, neurons: l.neurons, recurrent: w.recurrent, recurrent_bias: w.recurrent_bias });
        }
        Network::new(self.input_shape.clone(), layers)
    }

    /// Weights drawn uniformly in `+-gain / sqrt(fan_in)` (PyTorch's default scale) from `seed`;
    /// biases zero.
    pub fn init(&self, seed: u64, gain: f32) -> Result<Vec<LayerWeights>> {
        self.init_with_recurrent_gain(seed, gain, gain)
    }

    /// [`Self::init`] with the recurrent weights drawn at their own scale, `recurrent_gain` (0:
    /// zero, so the network starts feed-forward). The other weights are those of
    /// [`Self::init`] with the same seed and `gain`, whatever `recurrent_gain` is.
    pub fn init_with_recurrent_gain(&self, seed: u64, gain: f32, recurrent_gain: f32) -> Result<Vec<LayerWeights>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut draw = |shape: &[usize], fan_in: usize, gain: f32| -> Vec<f32> {
            let bound = gain.abs() / (fan_in.max(1) as f32).sqrt();
            let n = shape.iter().product::<usize>();
            if bound > 0.0 {
                (0..n).map(|_| rng.random_range(-bound..bound)).collect()
            } else {
                // the same draws as at any other scale, so later tensors do not move
                (0..n).map(|_| rng.random_range(-1.0f32..1.0) * 0.0).collect()
            }
        };
        Ok(self
            .shapes()?
            .iter()
            .map(|s| {
                let fan_in = if s.weight.is_empty() { 1 } else { s.weight[1..].iter().product() };
                LayerWeights {
                    weight: if s.weight.is_empty() { Vec::new() } else { draw(&s.weight, fan_in, gain) },
                    bias: (!s.bias.is_empty()).then(|| vec![0.0; s.bias[0]]),
                    recurrent: (!s.recurrent.is_empty()).then(|| draw(&s.recurrent, s.recurrent[0], recurrent_gain)),
                    recurrent_bias: (!s.recurrent_bias.is_empty()).then(|| vec![0.0; s.recurrent_bias[0]]),
                }
            })
            .collect())
    }
}

/// Several trained networks of one dense architecture as one network: the members side by side
/// in every hidden layer (the first layer's weights stacked, as the members share the input; the
/// later hidden layers and every recurrent matrix block-diagonal, so no member sees another's
/// spikes) and their leaky-integrator readouts summed into one (the weights placed side by side,
/// the biases added). Each output membrane is then the sum of the members' at every step, exactly
/// (an ensemble's soft vote taken at each step, before the maximum over time). `members` holds
/// each member's weights for `spec`.
pub fn ensemble(spec: &NetworkSpec, members: &[Vec<LayerWeights>]) -> Result<(NetworkSpec, Vec<LayerWeights>)> {
    let shapes = spec.shapes()?;
    let n_layers = spec.layers.len();
    let m = members.len();
    let refuse = |why: String| Err(Error::network(format!("ensemble: {why}")));
    if m == 0 {
        return refuse("no members".into());
    }
    if n_layers < 2 || spec.input_shape.len() != 1 {
        return refuse("needs a flat input and at least one hidden layer before the readout".into());
    }
    for (k, l) in spec.layers.iter().enumerate() {
        if !matches!(l.op, OpSpec::Dense { .. }) || l.recurrent_bias {
            return refuse(format!("layer {k} is not a dense layer without a recurrent bias"));
        }
    }
    match spec.layers[n_layers - 1].neurons {
        Some(p) if p.kind == NeuronKind::Li && p.v_leak == 0.0 && !spec.layers[n_layers - 1].recurrent => {}
        _ => return refuse("the readout must be leaky integrators at rest at 0, without recurrence".into()),
    }
    for (j, w) in members.iter().enumerate() {
        // checks every length against the spec
        spec.build(w.clone()).map_err(|e| Error::network(format!("ensemble member {j}: {e}")))?;
    }
    let mut layers = spec.layers.clone();
    let mut weights = Vec::with_capacity(n_layers);
    for (k, s) in shapes.iter().enumerate() {
        let (n_out, n_in) = (s.weight[0], s.weight[1]);
        let last = k + 1 == n_layers;
        let (rows, cols) = (if last { n_out } else { n_out * m }, if k == 0 { n_in } else { n_in * m });
        let mut weight = vec![0.0f32; rows * cols];
        for (j, w) in members.iter().enumerate() {
            let (row0, col0) = (if last { 0 } else { j * n_out }, if k == 0 { 0 } else { j * n_in });
            for o in 0..n_out {
                for i in 0..n_in {
                    weight[(row0 + o) * cols + col0 + i] += w[k].weight[o * n_in + i];
                }
            }
        }
        let bias = members[0][k].bias.as_ref().map(|_| {
            if last {
                let mut b = vec![0.0f32; n_out];
                for w in members {
                    b.iter_mut().zip(w[k].bias.iter().flatten()).for_each(|(x, y)| *x += y);
                }
                b
            } else {
                members.iter().flat_map(|w| w[k].bias.iter().flatten().copied()).collect()
            }
        });
        let recurrent = members[0][k].recurrent.as_ref().map(|_| {
            let n = n_out * m;
            let mut r = vec![0.0f32; n * n];
            for (j, w) in members.iter().enumerate() {
                for (o, row) in w[k].recurrent.as_deref().unwrap_or(&[]).chunks(n_out).enumerate() {
                    r[(j * n_out + o) * n + j * n_out..][..n_out].copy_from_slice(row);
                }
            }
            r
        });
        if !last {
            layers[k].op = OpSpec::Dense { n_out: n_out * m };
        }
        weights.push(LayerWeights { weight, bias, recurrent, recurrent_bias: None });
    }
    let merged = NetworkSpec { input_shape: spec.input_shape.clone(), layers };
    merged.build(weights.clone())?;
    Ok((merged, weights))
}

impl Network {
    /// The architecture of this network (inverse of [`NetworkSpec::build`]).
    pub fn spec(&self) -> NetworkSpec {
        let layers = self
            .layers
            .iter()
            .map(|l| LayerSpec {
                op: match &l.op {
                    Op::Dense { n_out, .. } => OpSpec::Dense { n_out: *n_out },
                    Op::Conv2d { out_channels, kernel, stride, padding, .. } => OpSpec::Conv2d {
                        out_channels: *out_channels,
                        kernel: *kernel,
                        stride: *stride,
                        padding: *padding,
                    },
                    Op::Pool { kind, kernel, stride, .. } => {
                        OpSpec::Pool { kind: *kind, kernel: *kernel, stride: *stride }
                    }
                },
                neurons: l.neurons,
                recurrent: l.recurrent.is_some(),
                bias: l.op.bias().is_some(),
                recurrent_bias: l.recurrent_bias.is_some(),
            })
            .collect();
        NetworkSpec { input_shape: self.input_shape.clone(), layers }
    }

    /// Every layer's weights (inverse of [`NetworkSpec::build`]).
    pub fn weights(&self) -> Vec<LayerWeights> {
        self.layers
            .iter()
            .map(|l| LayerWeights {
                weight: match &l.op {
                    Op::Dense { weight, .. } | Op::Conv2d { weight, .. } => weight.clone(),
                    Op::Pool { .. } => Vec::new(),
                },
                bias: l.op.bias().map(<[f32]>::to_vec),
                recurrent: l.recurrent.clone(),
                recurrent_bias: l.recurrent_bias.clone(),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::peers_conv;

    #[test]
    fn spec_and_weights_rebuild_the_network() {
        let net = peers_conv(3, 1.0);
        let again = net.spec().build(net.weights()).unwrap();
        assert_eq!(again, net);
    }

    #[test]
    fn an_ensemble_runs_its_members_side_by_side_and_sums_their_readouts() {
        use crate::network::{forward_dense_traced, random_input};
        use crate::neuron::Reset;
        let dense = |n_out, neurons, recurrent| LayerSpec {
            op: OpSpec::Dense { n_out },
            neurons: Some(neurons),
            recurrent,
            bias: true,
            recurrent_bias: false,
        };
        let hidden = NeuronParams::cuba_lif(0.8, 0.9).with_reset(Reset::Subtract);
        let spec = NetworkSpec {
            input_shape: vec![6],
            layers: vec![
                dense(5, hidden, true),
                dense(4, NeuronParams::lif(0.85), false),
                dense(3, NeuronParams::leaky_integrator(0.95), false),
            ],
        };
        // a recurrent scale of zero leaves the tensors drawn after the recurrent ones in place
        let (plain, quiet) = (spec.init(5, 1.0).unwrap(), spec.init_with_recurrent_gain(5, 1.0, 0.0).unwrap());
        assert!(
            quiet[1..] == plain[1..] && quiet[0].weight == plain[0].weight && quiet[0].recurrent != plain[0].recurrent
        );
        let mut members: Vec<Vec<LayerWeights>> = (1..=3).map(|seed| spec.init(seed, 2.0).unwrap()).collect();
        for (j, w) in members.iter_mut().enumerate() {
            for (k, l) in w.iter_mut().enumerate() {
                l.bias = l.bias.take().map(|b| b.iter().map(|_| 0.1 * (j + k) as f32 - 0.1).collect());
            }
        }
        let (merged, weights) = ensemble(&spec, &members).unwrap();
        let net = merged.build(weights).unwrap();
        assert_eq!((net.n_inputs(), net.n_outputs()), (6, 3));
        let steps = 30;
        let input = random_input(9, steps, 6, 0.3);
        let (record, trace) = forward_dense_traced(&net, &input, steps).unwrap();
        let runs: Vec<_> = members
            .iter()
            .map(|w| forward_dense_traced(&spec.build(w.clone()).unwrap(), &input, steps).unwrap())
            .collect();
        // each hidden layer: the members' spikes side by side, step by step
        for (k, n) in [(0usize, 5u32), (1, 4)] {
            for t in 0..steps {
                let want: Vec<u32> = runs
                    .iter()
                    .enumerate()
                    .flat_map(|(j, (r, _))| r.spikes[k][t].iter().map(move |&i| i + j as u32 * n))
                    .collect();
                assert_eq!(record.spikes[k][t], want, "layer {k}, step {t}");
            }
        }
        assert!(record.spikes[0].iter().map(Vec::len).sum::<usize>() > 0, "the test needs spikes");
        // the readout: the sum of the members' membranes at every step
        for (x, got) in trace.v[2].iter().enumerate() {
            let want: f32 = runs.iter().map(|(_, tr)| tr.v[2][x]).sum();
            assert!((got - want).abs() <= 1e-5 * (1.0 + want.abs()), "readout {x}: {got} vs {want}");
        }
        // what it cannot merge is refused
        assert!(ensemble(&spec, &[]).is_err());
        let mut short = members[0].clone();
        short[1].weight.pop();
        let e = ensemble(&spec, &[members[0].clone(), short]).unwrap_err().to_string();
        assert!(e.contains("member 1") && e.contains("layer 1"), "{e}");
        let mut spiking = spec.clone();
        spiking.layers[2].neurons = Some(NeuronParams::lif(0.9));
        assert!(ensemble(&spiking, &members).unwrap_err().to_string().contains("readout"));
    }

    #[test]
    fn shapes_follow_the_ops() {
        let spec = NetworkSpec {
            input_shape: vec![2, 10, 12],
            layers: vec![
                LayerSpec {
                    op: OpSpec::Conv2d { out_channels: 4, kernel: [3, 3], stride: [2, 2], padding: [1, 1] },
                    neurons: Some(NeuronParams::lif(0.9)),
                    recurrent: false,
                    bias: true,
                    recurrent_bias: false,
                },
                LayerSpec {
                    op: OpSpec::Pool { kind: PoolKind::Sum, kernel: [2, 2], stride: [2, 2] },
                    neurons: None,
                    recurrent: false,
                    bias: false,
                    recurrent_bias: false,
                },
                LayerSpec {
                    op: OpSpec::Dense { n_out: 5 },
                    neurons: Some(NeuronParams::lif(0.9)),
                    recurrent: true,
                    bias: false,
                    recurrent_bias: false,
                },
            ],
        };
        let s = spec.shapes().unwrap();
        assert_eq!(s[0].weight, vec![4, 2, 3, 3]);
        assert_eq!(s[0].output, vec![4, 5, 6]);
        assert_eq!(s[1].output, vec![4, 2, 3]);
        assert_eq!(s[2].weight, vec![5, 24]);
        assert_eq!(s[2].recurrent, vec![5, 5]);
        let net = spec.build(spec.init(1, 1.0).unwrap()).unwrap();
        assert_eq!(net.n_outputs(), 5);
        // a weight of the wrong length is refused with the layer named
        let mut w = spec.init(1, 1.0).unwrap();
        w[2].weight.pop();
        let e = spec.build(w).unwrap_err().to_string();
        assert!(e.contains("layer 2: weight"), "{e}");
        // the recurrent scale moves the recurrent weights alone
        let plain = spec.init(3, 0.5).unwrap();
        assert_eq!(spec.init_with_recurrent_gain(3, 0.5, 0.5).unwrap(), plain);
        let quiet = spec.init_with_recurrent_gain(3, 0.5, 0.0).unwrap();
        let small = spec.init_with_recurrent_gain(3, 0.5, 0.05).unwrap();
        for w in [&quiet, &small] {
            assert!(w.iter().zip(&plain).all(|(a, b)| a.weight == b.weight && a.bias == b.bias));
        }
        assert!(quiet[2].recurrent.as_ref().unwrap().iter().all(|&r| r == 0.0));
        let (r_small, r_plain) = (small[2].recurrent.as_ref().unwrap(), plain[2].recurrent.as_ref().unwrap());
        assert!(r_small.iter().zip(r_plain).all(|(a, b)| (a * 10.0 - b).abs() < 1e-6 && *b != 0.0));
    }
}
