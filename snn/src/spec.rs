//! A network's architecture without its weights: what a trainer builds and what a model file
//! records, so that a model can be rebuilt, checked against its weights and run by the engine.

use crate::error::{Error, Result};
use crate::network::{Layer, Network, Op, PoolKind};
use crate::neuron::NeuronParams;
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
            return Err(Error::Network(format!(
                "a network needs layers and a non-empty input shape, got {:?}",
                self.input_shape
            )));
        }
        let mut shape = self.input_shape.clone();
        let mut out = Vec::with_capacity(self.layers.len());
        for (k, l) in self.layers.iter().enumerate() {
            let bad = |m: String| Error::Network(format!("layer {k}: {m}"));
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
            return Err(Error::Network(format!("{} layers of weights for {} layers", weights.len(), shapes.len())));
        }
        let mut layers = Vec::with_capacity(shapes.len());
        for (k, ((l, s), w)) in self.layers.iter().zip(&shapes).zip(weights).enumerate() {
            let check = |name: &str, want: &[usize], got: Option<&Vec<f32>>| -> Result<()> {
                let n: usize = if want.is_empty() { 0 } else { want.iter().product() };
                let len = got.map_or(0, Vec::len);
                if len != n || (want.is_empty() != got.is_none()) {
                    return Err(Error::Network(format!(
                        "layer {k}: {name} has {len} values, its shape {want:?} needs {n}"
                    )));
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
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut draw = |shape: &[usize], fan_in: usize| -> Vec<f32> {
            let bound = gain / (fan_in.max(1) as f32).sqrt();
            (0..shape.iter().product::<usize>()).map(|_| rng.random_range(-bound..bound)).collect()
        };
        Ok(self
            .shapes()?
            .iter()
            .map(|s| {
                let fan_in = if s.weight.is_empty() { 1 } else { s.weight[1..].iter().product() };
                LayerWeights {
                    weight: if s.weight.is_empty() { Vec::new() } else { draw(&s.weight, fan_in) },
                    bias: (!s.bias.is_empty()).then(|| vec![0.0; s.bias[0]]),
                    recurrent: (!s.recurrent.is_empty()).then(|| draw(&s.recurrent, s.recurrent[0])),
                    recurrent_bias: (!s.recurrent_bias.is_empty()).then(|| vec![0.0; s.recurrent_bias[0]]),
                }
            })
            .collect())
    }
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
    }
}
