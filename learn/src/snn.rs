//! The SNN's time-stepped twin on burn, for backpropagation through time with surrogate
//! gradients. It runs the same discrete update as [`snn::neuron::NeuronParams::step`] (and so as
//! the event-driven engine in stepped mode), on dense tensors of a batch:
//!
//! ```text
//! u[t] = op(x[t]) (+ bias) (+ R z[t-1])          the layer's input
//! i[t] = alpha i[t-1] + u[t]                      CubaLIF only
//! v'[t] = beta v[t-1] + (1 - beta) v_leak + i[t]  (IF: beta = 1)
//! z[t] = H(v'[t] - v_th)                          forward: the step; backward: the surrogate
//! v[t] = v_reset where z[t] (Zero) or v'[t] - v_th z[t] (Subtract); the reset is detached
//! ```
//!
//! With [`SnnTwin::chip`] set to Speck, the forward pass is Sinabs's model of the chip
//! ([`snn::chip::speck`]) in float units, for quantisation-aware training: each spiking layer's
//! weights fake-quantised to 8 bits with Sinabs's one scale per layer (the value rounded, the
//! gradient straight through), its threshold rounded at that scale, `z[t] = floor(v'[t] / v_th)`
//! spikes for `v' > 0` (`MultiSpike`; backward: the surrogate at the nearest threshold crossing),
//! the reset per spike and the membrane's floor at the 16-bit minimum.
//!
//! With [`SnnTwin::chip`] set to Loihi 2, each layer's weights (and recurrent weights) are
//! fake-quantised on the 8-bit grid [`snn::chip::loihi2::map`] puts them on (one scale per layer
//! from its largest weight and threshold, one exponent per block) and the threshold is the
//! integer one; the neurons are the chip's (12-bit decays, reset to zero, set by the recipe). The
//! fixed-point state's rounding and the chip's latency are left out (the latency delays the
//! output without changing it).
//!
//! A leaky-integrator output layer never fires; its readout is `max(0, max_t v[t])`, what the
//! engine's [`snn::engine::EngineState::output_v_max`] keeps; its gradient passes the clamp at
//! zero straight through (a straight-through estimator), so no class's readout can die.

use burn::module::{Module, Param};
use burn::tensor::module::{avg_pool2d, conv2d};
use burn::tensor::ops::{AvgPoolOptions, ConvOptions};
use burn::tensor::{Device, Distribution, Tensor, TensorData};
use snn::model_file::Readout;
use snn::network::{Network, PoolKind};
use snn::neuron::{NeuronKind, NeuronParams, Reset, Surrogate};
use snn::spec::{LayerShapes, LayerWeights, NetworkSpec, OpSpec};

/// One layer's trainable tensors. Dense and recurrent weights are kept `[in, out]` (burn's
/// layout, transposed against the engine's `[out, in]`).
#[derive(Module, Debug)]
pub struct LayerParams {
    pub dense: Option<Param<Tensor<2>>>,
    pub conv: Option<Param<Tensor<4>>>,
    pub bias: Option<Param<Tensor<1>>>,
    pub recurrent: Option<Param<Tensor<2>>>,
}

#[derive(Module, Debug)]
pub struct SnnParams {
    pub layers: Vec<LayerParams>,
}

fn transpose(w: &[f32], rows: usize, cols: usize) -> Vec<f32> {
    let mut t = vec![0.0; w.len()];
    for r in 0..rows {
        for c in 0..cols {
            t[c * rows + r] = w[r * cols + c];
        }
    }
    t
}

fn values<const D: usize>(t: &Tensor<D>) -> Vec<f32> {
    t.to_data().convert::<f32>().try_into_vec::<f32>().expect("float tensors read back as f32")
}

impl SnnParams {
    /// Parameters holding `weights` (engine layouts), on `device`.
    pub fn from_weights(spec: &NetworkSpec, weights: &[LayerWeights], device: &Device) -> snn::Result<SnnParams> {
        let shapes = spec.shapes()?;
        // building checks every length against the spec
        spec.build(weights.to_vec())?;
        let layers = shapes
            .iter()
            .zip(weights)
            .zip(&spec.layers)
            .map(|((s, w), l)| {
                let p2 = |data: Vec<f32>, shape: [usize; 2]| {
                    Param::from_tensor(Tensor::<2>::from_data(TensorData::new(data, shape), device))
                };
                let (dense, conv) = match l.op {
                    OpSpec::Dense { .. } => {
                        let (o, i) = (s.weight[0], s.weight[1]);
                        (Some(p2(transpose(&w.weight, o, i), [i, o])), None)
                    }
                    OpSpec::Conv2d { .. } => {
                        let shape: [usize; 4] = s.weight.clone().try_into().expect("conv weights are 4-d");
                        let t = Tensor::<4>::from_data(TensorData::new(w.weight.clone(), shape), device);
                        (None, Some(Param::from_tensor(t)))
                    }
                    OpSpec::Pool { .. } => (None, None),
                };
                let bias = w
                    .bias
                    .as_ref()
                    .map(|b| Param::from_tensor(Tensor::<1>::from_data(TensorData::new(b.clone(), [b.len()]), device)));
                let recurrent = w.recurrent.as_ref().map(|r| {
                    let n = s.recurrent[0];
                    p2(transpose(r, n, n), [n, n])
                });
                LayerParams { dense, conv, bias, recurrent }
            })
            .collect();
        Ok(SnnParams { layers })
    }

    /// The weights in engine layouts.
    pub fn weights(&self, spec: &NetworkSpec) -> snn::Result<Vec<LayerWeights>> {
        let shapes = spec.shapes()?;
        Ok(self
            .layers
            .iter()
            .zip(&shapes)
            .map(|(p, s)| LayerWeights {
                weight: match (&p.dense, &p.conv) {
                    (Some(d), _) => transpose(&values(&d.val()), s.weight[1], s.weight[0]),
                    (_, Some(c)) => values(&c.val()),
                    _ => Vec::new(),
                },
                bias: p.bias.as_ref().map(|b| values(&b.val())),
                recurrent: p.recurrent.as_ref().map(|r| {
                    let n = s.recurrent[0];
                    transpose(&values(&r.val()), n, n)
                }),
                recurrent_bias: None,
            })
            .collect())
    }

    /// The network the engine runs.
    pub fn network(&self, spec: &NetworkSpec) -> snn::Result<Network> {
        spec.build(self.weights(spec)?)
    }
}

/// What a forward pass gives.
pub struct Forward {
    /// `[batch, classes]`: spike counts or max membranes.
    pub logits: Tensor<2>,
    /// Spikes per layer with spiking neurons, summed over batch and time (for monitoring).
    pub spikes: Vec<Tensor<1>>,
}

/// The time-stepped network on burn.
#[derive(Debug, Clone)]
pub struct SnnTwin {
    pub spec: NetworkSpec,
    pub shapes: Vec<LayerShapes>,
    pub surrogate: Surrogate,
    pub readout: Readout,
    /// Backpropagate the readout's clamp at zero as it is (zero gradient below it) instead of
    /// straight through.
    pub clamped_readout_gradient: bool,
    /// Quantisation-aware: the chip whose arithmetic the forward pass models (Speck and Loihi 2;
    /// Xylo's runs on the sparse trainer).
    pub chip: Option<snn::chip::Chip>,
}

/// The surrogate derivative at `xd` (detached).
fn surrogate_derivative(xd: Tensor<2>, surrogate: Surrogate) -> Tensor<2> {
    match surrogate {
        Surrogate::FastSigmoid { slope } => (xd.abs() * slope + 1.0).powi_scalar(2).recip(),
        Surrogate::Arctan { alpha } => {
            let a = xd * (std::f32::consts::PI * alpha / 2.0);
            (a.clone() * a + 1.0).recip() * (alpha / 2.0)
        }
        Surrogate::Triangle { width } => (xd.abs() * (-1.0 / width) + 1.0).clamp_min(0.0) / width,
    }
}

/// One spiking layer's quantisation for Speck: Sinabs's scale of its current weights, the
/// threshold and floor at that scale.
#[derive(Debug, Clone, Copy)]
struct SpeckQuant {
    scale: f32,
    /// The integer threshold.
    threshold: f32,
    /// The floor in float units.
    floor: f32,
}

/// One layer's quantisation for Loihi 2 ([`snn::chip::loihi2::map`]'s rule on its current
/// weights): the grid steps of its feed-forward and recurrent weights in float units, and the
/// threshold the integer `vth` stands for.
#[derive(Debug, Clone, Copy)]
struct Loihi2Quant {
    /// Float units per step of the 8-bit mantissa (`2 * 2^exp / scale`).
    step_ff: f32,
    step_rec: f32,
    v_th: f32,
}

/// The largest magnitude of `w` (detached).
fn max_abs<const D: usize>(w: &Tensor<D>) -> f32 {
    w.clone().detach().abs().max().into_scalar::<f32>()
}

/// The largest and smallest of a layer's dense or convolution weights (detached); `None` for a
/// layer without them.
fn weight_range(p: &LayerParams) -> Option<(f32, f32)> {
    fn range<const D: usize>(w: Tensor<D>) -> (f32, f32) {
        let w = w.detach();
        (w.clone().max().into_scalar::<f32>(), w.min().into_scalar::<f32>())
    }
    match (&p.dense, &p.conv) {
        (Some(w), _) => Some(range(w.val())),
        (_, Some(w)) => Some(range(w.val())),
        _ => None,
    }
}

/// One layer's weights for one forward pass (fake-quantised for a chip).
struct LayerTensors {
    dense: Option<Tensor<2>>,
    conv: Option<Tensor<4>>,
    bias: Option<Tensor<1>>,
}

/// `w` with the value of its 8-bit quantisation at `scale` and the gradient of `w`.
fn fake_quantise<const D: usize>(w: Tensor<D>, scale: f32) -> Tensor<D> {
    let q = (w.clone().detach() * scale).round().clamp(-128.0, 127.0) / scale;
    w.clone() + (q - w.detach())
}

/// The spike: the step forward, `d(x)` backward (`x * d(x).detach()` carries the gradient; its
/// value cancels exactly).
fn spike(x: Tensor<2>, surrogate: Surrogate) -> Tensor<2> {
    let xd = x.clone().detach();
    let d = surrogate_derivative(xd.clone(), surrogate);
    let hard = xd.greater_elem(0.0).float();
    let soft = x * d;
    hard + soft.clone() - soft.detach()
}

impl SnnTwin {
    pub fn new(spec: NetworkSpec, surrogate: Surrogate, readout: Readout) -> snn::Result<SnnTwin> {
        let shapes = spec.shapes()?;
        crate::sparse::check_trainable(&spec, readout)?;
        Ok(SnnTwin { spec, shapes, surrogate, readout, clamped_readout_gradient: false, chip: None })
    }

    /// Runs `input`: one `[batch, n_inputs]` tensor per step.
    pub fn forward(&self, params: &SnnParams, input: &[Tensor<2>]) -> Forward {
        self.forward_dropout(params, input, 0.0)
    }

    /// [`Self::forward`] in training with neuron dropout: each hidden spiking neuron is silenced
    /// with probability `dropout` for a whole sample (the same neurons at every step), the others'
    /// spikes scaled by `1 / (1 - dropout)`; drawn from the device's seeded generator.
    pub fn forward_dropout(&self, params: &SnnParams, input: &[Tensor<2>], dropout: f64) -> Forward {
        let steps = input.len();
        let n_layers = self.spec.layers.len();
        let batch = input.first().map_or(0, |x| x.dims()[0]);
        let device = input.first().map(|x| x.device()).unwrap_or_default();
        let zeros = |n: usize| Tensor::<2>::zeros([batch, n], &device);
        let mut v: Vec<Option<Tensor<2>>> = vec![None; n_layers];
        let mut cur: Vec<Option<Tensor<2>>> = vec![None; n_layers];
        let mut prev: Vec<Option<Tensor<2>>> = vec![None; n_layers];
        let mut counts: Vec<Option<Tensor<2>>> = vec![None; n_layers];
        let mut out_v: Vec<Tensor<2>> = Vec::new();
        let mut masks: Vec<Option<Tensor<2>>> = vec![None; n_layers];
        let speck = self.chip == Some(snn::chip::Chip::Speck);
        // Loihi 2: each layer's weights on its 8-bit grid (one exponent per block), its threshold
        // the integer one, once per pass
        let lq: Vec<Option<Loihi2Quant>> = self
            .spec
            .layers
            .iter()
            .zip(&params.layers)
            .map(|(l, p)| {
                use ::snn::chip::loihi2;
                let np = l.neurons?;
                if self.chip != Some(snn::chip::Chip::Loihi2) {
                    return None;
                }
                let (hi, lo) = weight_range(p)?;
                let max_ff = hi.abs().max(lo.abs());
                let v_th = if np.v_th > 0.0 { np.v_th } else { 1.0 };
                let scale = loihi2::input_scale(max_ff, v_th);
                let step = |max: f32| 2.0 * 2f32.powi(loihi2::weight_exp_for(max as f64 * scale as f64) as i32) / scale;
                Some(Loihi2Quant {
                    step_ff: step(max_ff),
                    step_rec: p.recurrent.as_ref().map_or(1.0, |r| step(max_abs(&r.val()))),
                    v_th: (v_th * scale).round().clamp(1.0, loihi2::VTH_MAX as f32) / scale,
                })
            })
            .collect();
        // Speck: each spiking layer's weights fake-quantised once per pass
        let quant: Vec<Option<SpeckQuant>> = self
            .spec
            .layers
            .iter()
            .zip(&params.layers)
            .map(|(l, p)| {
                let np = l.neurons?;
                if !speck {
                    return None;
                }
                let (hi, lo) = weight_range(p)?;
                let scale = snn::chip::speck::discretization_scale([hi, lo], 8);
                let low = snn::chip::speck::THRESHOLD_LOW as f32;
                let scale = scale.min(snn::chip::speck::discretization_scale([low / scale, np.v_th], 16));
                Some(SpeckQuant { scale, threshold: (np.v_th * scale).round().max(1.0), floor: low / scale })
            })
            .collect();
        let weights: Vec<LayerTensors> = params
            .layers
            .iter()
            .zip(quant.iter().zip(&lq))
            .map(|(p, (q, l))| {
                // the fake quantiser's scale: Speck's, or Loihi 2's grid step's inverse
                let s = q.map(|q| q.scale).or(l.map(|l| 1.0 / l.step_ff));
                let fq2 = |w: Tensor<2>| s.map_or(w.clone(), |s| fake_quantise(w, s));
                let fq4 = |w: Tensor<4>| s.map_or(w.clone(), |s| fake_quantise(w, s));
                LayerTensors {
                    dense: p.dense.as_ref().map(|w| fq2(w.val())),
                    conv: p.conv.as_ref().map(|w| fq4(w.val())),
                    bias: p.bias.as_ref().map(|b| b.val()),
                }
            })
            .collect();
        for x_t in input {
            let mut x = x_t.clone();
            for (k, ((l, s), (p, w))) in
                self.spec.layers.iter().zip(&self.shapes).zip(params.layers.iter().zip(&weights)).enumerate()
            {
                let mut u = self.op(l.op, s, w, x, batch);
                let Some(np) = l.neurons else {
                    x = u;
                    continue;
                };
                if let (Some(r), Some(z)) = (&p.recurrent, &prev[k]) {
                    let r = match lq[k] {
                        Some(l) => fake_quantise(r.val(), 1.0 / l.step_rec),
                        None => r.val(),
                    };
                    u = u + z.clone().matmul(r);
                }
                let n = u.dims()[1];
                let drive = match np.kind {
                    NeuronKind::CubaLif => {
                        let i = match cur[k].take() {
                            Some(i) => i * np.alpha + u,
                            None => u,
                        };
                        cur[k] = Some(i.clone());
                        i
                    }
                    _ => u,
                };
                let vk = v[k].take().unwrap_or_else(|| zeros(n));
                // the engine's order: beta v + leak + drive
                let leak = np.leak_term();
                let mut vn = vk * np.beta;
                if leak != 0.0 {
                    vn = vn + leak;
                }
                let vn = vn + drive;
                if np.kind == NeuronKind::Li {
                    out_v.push(vn.clone());
                    v[k] = Some(vn.clone());
                    x = vn;
                    continue;
                }
                let z = match quant[k] {
                    Some(q) if np.kind == NeuronKind::If => {
                        // Sinabs's MultiSpike on the chip's integers: floor(V / T) for V > 0
                        let vi = (vn.clone().detach() * q.scale).round();
                        let n_hard = (vi.clone() / q.threshold).floor().clamp_min(0.0);
                        // backward: the surrogate at the nearest threshold crossing
                        let crossing = (vi / q.threshold).round().clamp_min(1.0) * (q.threshold / q.scale);
                        let xs = vn.clone() - crossing;
                        let soft = xs.clone() * surrogate_derivative(xs.detach(), self.surrogate);
                        let z = n_hard.clone() + soft.clone() - soft.detach();
                        let kept = match np.reset {
                            Reset::Subtract => vn - n_hard * (q.threshold / q.scale),
                            Reset::Zero => vn * n_hard.equal_elem(0.0).float(),
                        };
                        v[k] = Some(kept.clamp_min(q.floor));
                        z
                    }
                    _ => {
                        let v_th = lq[k].map_or(np.v_th, |l| l.v_th);
                        let z = spike(vn.clone() - v_th, self.surrogate);
                        let zd = z.clone().detach();
                        v[k] = Some(reset(vn, zd, &np));
                        z
                    }
                };
                counts[k] = Some(match counts[k].take() {
                    Some(c) => c + z.clone(),
                    None => z.clone(),
                });
                if l.recurrent {
                    prev[k] = Some(z.clone());
                }
                x = if dropout > 0.0 && k + 1 < n_layers {
                    let mask = masks[k].get_or_insert_with(|| {
                        Tensor::<2>::random([batch, n], Distribution::Bernoulli(1.0 - dropout), &device)
                            / (1.0 - dropout) as f32
                    });
                    z * mask.clone()
                } else {
                    z
                };
            }
        }
        let logits = match self.readout {
            Readout::SpikeCount => counts[n_layers - 1].clone().unwrap_or_else(|| zeros(self.n_outputs())),
            Readout::MaxMembrane => {
                if steps == 0 {
                    zeros(self.n_outputs())
                } else {
                    // forward: max(0, max_t v), as the engine keeps it; backward: as if
                    // unclamped, so a readout whose membrane stays below zero still learns
                    // (with the clamp's zero gradient such a class could never be predicted again)
                    let m = Tensor::stack::<3>(out_v, 0).max_dim(0).squeeze_dim::<2>(0);
                    if self.clamped_readout_gradient {
                        m.clamp_min(0.0)
                    } else {
                        m.clone() + (m.clone().clamp_min(0.0) - m).detach()
                    }
                }
            }
        };
        let spikes = counts.into_iter().flatten().map(|c| c.sum_dim(0).squeeze_dim::<1>(0)).collect();
        Forward { logits, spikes }
    }

    pub fn n_outputs(&self) -> usize {
        self.shapes.last().map_or(0, |s| s.output.iter().product())
    }

    fn op(&self, op: OpSpec, s: &LayerShapes, p: &LayerTensors, x: Tensor<2>, batch: usize) -> Tensor<2> {
        let chw = |x: Tensor<2>| x.reshape([batch, s.input[0], s.input[1], s.input[2]]);
        let n_out: usize = s.output.iter().product();
        match op {
            OpSpec::Dense { .. } => {
                let w = p.dense.clone().expect("dense layers have weights");
                let y = x.matmul(w);
                match &p.bias {
                    Some(b) => y + b.clone().unsqueeze_dim::<2>(0),
                    None => y,
                }
            }
            OpSpec::Conv2d { stride, padding, .. } => {
                let w = p.conv.clone().expect("conv layers have weights");
                let y = conv2d(chw(x), w, p.bias.clone(), ConvOptions::new(stride, padding, [1, 1], 1));
                y.reshape([batch, n_out])
            }
            OpSpec::Pool { kind, kernel, stride } => {
                let opts = AvgPoolOptions {
                    kernel_size: kernel,
                    stride,
                    padding: [(0, 0); 2],
                    count_include_pad: true,
                    ceil_mode: false,
                };
                let y = avg_pool2d(chw(x), opts).reshape([batch, n_out]);
                match kind {
                    PoolKind::Avg => y,
                    PoolKind::Sum => y * (kernel[0] * kernel[1]) as f32,
                }
            }
        }
    }
}

fn reset(v: Tensor<2>, z: Tensor<2>, p: &NeuronParams) -> Tensor<2> {
    match p.reset {
        Reset::Subtract => v - z * p.v_th,
        Reset::Zero => {
            let kept = v * (z.clone().neg() + 1.0);
            if p.v_reset == 0.0 { kept } else { kept + z * p.v_reset }
        }
    }
}
