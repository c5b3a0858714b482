//! Chips as they compute: each chip's number formats (integer weights of a few bits, fixed-point
//! state with saturation, decays as bit shifts, integer thresholds), a mapping from a trained
//! floating-point [`Network`](crate::network::Network) into them, and a simulation of the chip's
//! arithmetic, stepped and event-driven, bit for bit the same.
//!
//! Each format is taken from the chip's toolchain sources and named with them. Only formats whose
//! arithmetic is published bit for bit are modelled:
//!
//! - [`Chip::Xylo`]: SynSense Xylo Audio 2 (SYNS61201), as XyloSim v2 (PyPI `xylosim` 0.1.3,
//!   `src/v2/cpp/XyloIAFNeuron.cpp` and `XyloLayer.cpp`, which Rockpool's `XyloSim` runs) computes
//!   it, with Rockpool's mapping of time constants to bit shifts (`xylo_graph_modules.py`:
//!   `dash = log2(tau / dt)`) and its quantisers (`rockpool.transform.quantize_methods`).
//!   See [`xylo`].
//! - [`Chip::Speck`]: SynSense Speck (DYNAP-CNN cores), as Sinabs 3.1.3 (PyPI `sinabs`,
//!   `backend/dynapcnn/discretize.py`, `chips/dynapcnn.py`, `layers/iaf.py` with `MultiSpike`)
//!   discretises and runs it. See [`speck`].
//! - [`Chip::Loihi2`]: Intel Loihi 2's fixed-point LIF neurons and synapses, as Lava 0.10.0's
//!   bit-accurate models compute them (PyPI `lava-nc`, `proc/lif/models.py` `PyLifModelBitAcc`,
//!   `proc/dense/models.py` `PyDenseModelBitAcc`). See [`loihi2`].
//!
//! SpiNNaker 2 is not modelled: its neurons are programs on ARM cores, whose arithmetic is the
//! program's, and its toolchain (py-spinnaker2) is neither on PyPI nor readable here, so no number
//! format could be taken from the vendor's code.
//!
//! ```
//! use snn::chip::xylo::{self, Quantisation, Run};
//! use snn::network::{Layer, Network, Op};
//! use snn::neuron::NeuronParams;
//!
//! // 2 inputs -> 3 CubaLIF -> 2 leaky-integrator readouts
//! let hidden = Op::Dense { n_in: 2, n_out: 3, weight: vec![0.9, -0.2, 0.5, 0.4, -0.7, 0.8], bias: None };
//! let out = Op::Dense { n_in: 3, n_out: 2, weight: vec![0.6, -0.3, 0.2, -0.1, 0.5, 0.4], bias: None };
//! let net = Network::new(vec![2], vec![
//!     Layer { op: hidden, neurons: Some(NeuronParams::cuba_lif(0.9, 0.95)), recurrent: None, recurrent_bias: None },
//!     Layer { op: out, neurons: Some(NeuronParams::leaky_integrator(0.9)), recurrent: None, recurrent_bias: None },
//! ]).unwrap();
//! let mapped = xylo::map(&net, Quantisation::Global).unwrap();
//! assert_eq!(mapped.spec.weights_in.len(), 2 * 3); // 8-bit, `[input][hidden]` as Rockpool's
//! let chip = mapped.spec.compile().unwrap(); // shared by every stream
//! let mut st = chip.state(); // one stream's own
//! for _ in 0..5 {
//!     chip.step(&mut st, &[0, 1], &[2, 1], Run::EventDriven).unwrap();
//! }
//! assert!(st.stats.synops > 0);
//! ```

pub mod loihi2;
pub mod speck;
pub mod xylo;

use serde::{Deserialize, Serialize};

/// Checks one step's input as every chip takes it: as many event counts as channels, the channels
/// ascending without repeats and below `n_in` (`step` names the step in the error).
pub(crate) fn check_step_input(channels: &[u32], events: &[u16], n_in: usize, step: u64) -> crate::Result<()> {
    if channels.len() != events.len() {
        return Err(crate::Error::input(format!(
            "{} channels and {} event counts at step {step}",
            channels.len(),
            events.len()
        )));
    }
    let mut prev: Option<u32> = None;
    for &c in channels {
        if c as usize >= n_in || prev.is_some_and(|p| p >= c) {
            return Err(crate::Error::input(format!(
                "input channel {c} at step {step} (channels ascending, fewer than {n_in})"
            )));
        }
        prev = Some(c);
    }
    Ok(())
}

/// A chip whose arithmetic the engine models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Chip {
    /// SynSense Xylo Audio 2 (SYNS61201).
    Xylo,
    /// SynSense Speck (DYNAP-CNN cores).
    Speck,
    /// Intel Loihi 2, as Lava's bit-accurate LIF and Dense models compute.
    Loihi2,
}

impl Chip {
    pub const ALL: [Chip; 3] = [Chip::Xylo, Chip::Speck, Chip::Loihi2];

    pub fn name(self) -> &'static str {
        match self {
            Chip::Xylo => "Xylo",
            Chip::Speck => "Speck",
            Chip::Loihi2 => "Loihi 2",
        }
    }

    /// The chip's number formats.
    pub fn format(self) -> NumberFormat {
        match self {
            Chip::Xylo => xylo::FORMAT,
            Chip::Speck => speck::FORMAT,
            Chip::Loihi2 => loihi2::FORMAT,
        }
    }

    /// The neurons nearest `p` that the chip computes as they are: its decays, its reset (what
    /// a network trained for the chip uses).
    pub fn neurons(self, p: crate::neuron::NeuronParams) -> crate::neuron::NeuronParams {
        match self {
            Chip::Xylo => xylo::neurons(p),
            // Speck's IF neurons have no decay to round, and reset either way
            Chip::Speck => p,
            Chip::Loihi2 => loihi2::neurons(p),
        }
    }
}

impl std::fmt::Display for Chip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How a chip decays its state each step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum DecayArithmetic {
    /// `x -= x >> dash` (arithmetic shift), at least one unit towards zero; `dash` of `bits` bits.
    BitShift { bits: u8 },
    /// `x * (2^bits - d) >> bits`, rounded towards zero; `d` of `bits` bits.
    Multiply { bits: u8 },
    /// No decay: integrate-and-fire neurons.
    None,
}

/// What a neuron does after it spikes, in the chip.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ChipReset {
    /// The threshold is subtracted once per spike, several spikes per step allowed.
    Subtract,
    /// Per layer, the threshold subtracted per spike or the membrane set to zero after a spike
    /// (`return_to_zero`); several spikes per step allowed.
    SubtractOrZero,
    /// The membrane set to zero after a spike; one spike per step.
    Zero,
}

/// A chip's number formats: what a model must become to run there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct NumberFormat {
    /// Signed integer weights.
    pub weight_bits: u8,
    /// Weights shifted left by up to this many bits before they reach the state (per weight
    /// matrix).
    pub max_weight_shift: u8,
    /// Signed integer synaptic current and membrane, saturating.
    pub state_bits: u8,
    /// Signed integer thresholds.
    pub threshold_bits: u8,
    pub decay: DecayArithmetic,
    pub reset: ChipReset,
    /// Spikes a hidden neuron may send in one step (`None`: as many as its membrane holds
    /// thresholds).
    pub max_spikes_per_step: Option<u8>,
    /// Spikes an output neuron may send in one step.
    pub max_output_spikes_per_step: Option<u8>,
    /// Input events per channel and step the chip takes, more are dropped (`None`: no cap).
    pub max_input_events_per_step: Option<u8>,
    /// Where these figures come from.
    pub source: &'static str,
}

/// A network mapped into one chip's formats, ready to run: shared by every stream
/// ([`ChipState`] is each stream's own).
#[derive(Debug, Clone, PartialEq)]
pub enum ChipModel {
    Xylo(Box<xylo::Xylo>),
    Speck(speck::Speck),
    Loihi2(loihi2::Loihi2),
}

/// One stream's state on a chip.
#[derive(Debug, Clone, PartialEq)]
pub enum ChipState {
    Xylo(Box<xylo::XyloState>),
    Speck(Box<speck::SpeckState>),
    Loihi2(Box<loihi2::Loihi2State>),
}

/// Work done by one stream on a chip.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct ChipWork {
    /// Input events the chip took (after Xylo's cap of 15 per channel and step).
    pub input_events: u64,
    /// Synaptic operations: one weight added to one state.
    pub synops: u64,
    /// Spikes of every neuron, output neurons included.
    pub spikes: u64,
    pub output_spikes: u64,
    /// Spikes per layer of neurons: Xylo's hidden and output neurons; each Speck core's; each
    /// Loihi 2 layer's.
    pub spikes_per_layer: Vec<u64>,
    /// Neurons updated (every neuron every step in a stepped run).
    pub neuron_updates: u64,
}

/// A network mapped into a chip's formats, with what the mapping changed.
#[derive(Debug, Clone, PartialEq)]
pub struct MappedModel {
    pub model: ChipModel,
    /// What the mapping changed, one sentence each.
    pub approximations: Vec<String>,
    /// Bit shifts of the input, recurrent and output weights (Xylo; zero elsewhere; Loihi 2's
    /// exponents per layer are in its spec).
    pub weight_shifts: [u8; 3],
}

impl ChipModel {
    /// Maps `net` into `chip`'s formats, quantised by `quantisation` and read out by `readout`
    /// (Speck counts output spikes, and quantises one scale per core: Sinabs's rule, which
    /// `Quantisation::Global` names; per-channel scales are refused there, since a core has one
    /// threshold).
    pub fn map(
        net: &crate::network::Network,
        chip: Chip,
        quantisation: xylo::Quantisation,
        readout: crate::model_file::Readout,
    ) -> crate::Result<MappedModel> {
        match chip {
            Chip::Xylo => {
                let mut m = xylo::map(net, quantisation)?;
                m.spec.readout = readout.into();
                let weight_shifts = [m.spec.weight_shift_in, m.spec.weight_shift_rec, m.spec.weight_shift_out];
                Ok(MappedModel {
                    approximations: m.approximations.iter().map(ToString::to_string).collect(),
                    model: ChipModel::Xylo(Box::new(m.spec.compile()?)),
                    weight_shifts,
                })
            }
            Chip::Speck => {
                if quantisation == xylo::Quantisation::Channel {
                    return Err(crate::Error::Chip {
                        chip,
                        layer: None,
                        what: "a Speck core has one threshold for all its neurons: one scale per core (global quantisation), not per channel".into(),
                    });
                }
                // what the network is decides first; then how it is read
                let m = speck::map(net)?;
                if readout != crate::model_file::Readout::SpikeCount {
                    return Err(crate::Error::Chip {
                        chip,
                        layer: None,
                        what: "Speck's output is spikes: the model must read out by counting them (it reads the highest membrane)".into(),
                    });
                }
                Ok(MappedModel {
                    approximations: m.approximations.iter().map(ToString::to_string).collect(),
                    model: ChipModel::Speck(m.spec.compile()?),
                    weight_shifts: [0; 3],
                })
            }
            Chip::Loihi2 => {
                if quantisation == xylo::Quantisation::Channel {
                    return Err(crate::Error::Chip {
                        chip,
                        layer: None,
                        what: "a Loihi 2 synapse block has one weight exponent and a layer one threshold: one scale per layer (global quantisation), not per channel".into(),
                    });
                }
                let m = loihi2::map(net, readout)?;
                Ok(MappedModel {
                    approximations: m.approximations.iter().map(ToString::to_string).collect(),
                    model: ChipModel::Loihi2(m.spec.compile()?),
                    weight_shifts: [0; 3],
                })
            }
        }
    }

    pub fn chip(&self) -> Chip {
        match self {
            ChipModel::Xylo(_) => Chip::Xylo,
            ChipModel::Speck(_) => Chip::Speck,
            ChipModel::Loihi2(_) => Chip::Loihi2,
        }
    }

    pub fn n_in(&self) -> usize {
        match self {
            ChipModel::Xylo(x) => x.spec().n_in,
            ChipModel::Speck(s) => s.spec().n_in(),
            ChipModel::Loihi2(s) => s.spec().n_in(),
        }
    }

    pub fn n_out(&self) -> usize {
        match self {
            ChipModel::Xylo(x) => x.spec().n_out,
            ChipModel::Speck(s) => s.spec().n_out(),
            ChipModel::Loihi2(s) => s.spec().n_out(),
        }
    }

    /// A stream at rest.
    pub fn state(&self) -> ChipState {
        match self {
            ChipModel::Xylo(x) => ChipState::Xylo(Box::new(x.state())),
            ChipModel::Speck(s) => ChipState::Speck(Box::new(s.state())),
            ChipModel::Loihi2(s) => ChipState::Loihi2(Box::new(s.state())),
        }
    }

    /// One step of one stream (`channels` ascending, their event counts in `events`).
    pub fn step(&self, st: &mut ChipState, channels: &[u32], events: &[u16], run: xylo::Run) -> crate::Result<()> {
        match (self, st) {
            (ChipModel::Xylo(x), ChipState::Xylo(s)) => x.step(s, channels, events, run),
            (ChipModel::Speck(x), ChipState::Speck(s)) => x.step(s, channels, events, run),
            (ChipModel::Loihi2(x), ChipState::Loihi2(s)) => x.step(s, channels, events, run),
            _ => Err(crate::Error::input("a stream's state belongs to another chip")),
        }
    }

    /// The output spikes of the stream's last step: (output neuron, spikes).
    pub fn out_spikes(&self, st: &ChipState) -> Vec<(usize, u32)> {
        match st {
            ChipState::Xylo(s) => {
                s.out_spikes.iter().enumerate().filter(|(_, n)| **n > 0).map(|(j, &n)| (j, n as u32)).collect()
            }
            ChipState::Speck(s) => s.last_out_spikes().iter().map(|&(j, n)| (j as usize, n)).collect(),
            ChipState::Loihi2(s) => {
                s.layers.last().map_or(Vec::new(), |l| l.fired.iter().map(|&j| (j as usize, 1)).collect())
            }
        }
    }

    /// Chip units of the readout per unit of the float network's: spike counts are counts; a
    /// membrane is in the output layer's scale (Loihi 2: `scale * 2^6`). Xylo's membranes are
    /// given in its own units (1).
    pub fn readout_scale(&self) -> f32 {
        match self {
            ChipModel::Loihi2(x) if x.spec().readout == crate::model_file::Readout::MaxMembrane => {
                x.spec().layers.last().map_or(1.0, |l| l.scale * (1u32 << loihi2::STATE_SHIFT) as f32)
            }
            _ => 1.0,
        }
    }

    /// The readout since rest, per output neuron.
    pub fn readout(&self, st: &ChipState) -> Vec<f32> {
        match (self, st) {
            (ChipModel::Xylo(x), ChipState::Xylo(s)) => x.readout(s),
            (ChipModel::Speck(x), ChipState::Speck(s)) => x.readout(s),
            (ChipModel::Loihi2(x), ChipState::Loihi2(s)) => x.readout(s),
            _ => Vec::new(),
        }
    }

    /// The stream's work since rest.
    pub fn work(st: &ChipState) -> ChipWork {
        match st {
            ChipState::Xylo(s) => ChipWork {
                input_events: s.stats.input_events,
                synops: s.stats.synops,
                spikes: s.stats.hidden_spikes + s.stats.output_spikes,
                output_spikes: s.stats.output_spikes,
                spikes_per_layer: vec![s.stats.hidden_spikes, s.stats.output_spikes],
                neuron_updates: s.stats.neuron_updates,
            },
            ChipState::Speck(s) => ChipWork {
                input_events: s.stats.input_events,
                synops: s.stats.synops,
                spikes: s.stats.spikes,
                output_spikes: s.stats.output_spikes,
                spikes_per_layer: s.stats.spikes_per_core.clone(),
                neuron_updates: s.stats.neuron_updates,
            },
            ChipState::Loihi2(s) => ChipWork {
                input_events: s.stats.input_events,
                synops: s.stats.synops,
                spikes: s.stats.spikes,
                output_spikes: s.stats.output_spikes,
                spikes_per_layer: s.stats.spikes_per_layer.clone(),
                neuron_updates: s.stats.neuron_updates,
            },
        }
    }

    /// Steps without input a sample runs after its last one for the output to answer it: Loihi
    /// 2's latency (one step per synapse block); none on Xylo and Speck, whose runs end with the
    /// input as their simulators' do.
    pub fn drain_steps(&self) -> usize {
        match self {
            ChipModel::Loihi2(x) => x.drain_steps(),
            _ => 0,
        }
    }

    /// Ends a sample: runs [`ChipModel::drain_steps`] steps without input. Call before
    /// [`ChipModel::readout`].
    pub fn finish(&self, st: &mut ChipState, run: xylo::Run) -> crate::Result<()> {
        for _ in 0..self.drain_steps() {
            self.step(st, &[], &[], run)?;
        }
        Ok(())
    }

    /// A whole sample from rest (then [`ChipModel::finish`]): its readout and the work.
    pub fn run_sample<'a>(
        &self,
        steps: impl IntoIterator<Item = (&'a [u32], &'a [u16])>,
        run: xylo::Run,
    ) -> crate::Result<(Vec<f32>, ChipWork)> {
        let mut st = self.state();
        for (channels, events) in steps {
            self.step(&mut st, channels, events, run)?;
        }
        self.finish(&mut st, run)?;
        Ok((self.readout(&st), ChipModel::work(&st)))
    }
}

#[cfg(test)]
pub(crate) mod test_nets {
    use crate::network::{Layer, Network, Op, PoolKind};
    use crate::neuron::NeuronParams;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// 2x8x8 -> conv 3x3 (4, padded) -> `p[0]` -> sum-pool 2 -> conv 3x3 (3, stride 2) -> `p[1]`
    /// -> dense 5 -> `p[2]`, weights drawn from `seed` (then, with `bias`, a bias on the second
    /// convolution).
    pub(crate) fn conv_pool_dense(seed: u64, p: [NeuronParams; 3], bias: bool) -> Network {
        conv_pool_dense_with(seed, p, bias, [4, 3])
    }

    /// [`conv_pool_dense`] with `channels` in its two convolutions.
    pub(crate) fn conv_pool_dense_with(seed: u64, p: [NeuronParams; 3], bias: bool, channels: [usize; 2]) -> Network {
        let [a, b] = channels;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut w = |n: usize, r: f32| (0..n).map(|_| rng.random_range(-r..r)).collect::<Vec<f32>>();
        let (w1, w2, wd) = (w(a * 2 * 9, 1.2), w(b * a * 9, 0.9), w(5 * b * 4, 1.0));
        let b2 = bias.then(|| w(b, 0.2));
        let c1 = Op::Conv2d {
            in_shape: [2, 8, 8],
            out_channels: a,
            kernel: [3, 3],
            stride: [1, 1],
            padding: [1, 1],
            weight: w1,
            bias: None,
        };
        let pool = Op::Pool { kind: PoolKind::Sum, in_shape: [a, 8, 8], kernel: [2, 2], stride: [2, 2] };
        let c2 = Op::Conv2d {
            in_shape: [a, 4, 4],
            out_channels: b,
            kernel: [3, 3],
            stride: [2, 2],
            padding: [1, 1],
            weight: w2,
            bias: b2,
        };
        let d = Op::Dense { n_in: b * 2 * 2, n_out: 5, weight: wd, bias: None };
        let layer = |op, p| Layer { op, neurons: Some(p), recurrent: None, recurrent_bias: None };
        Network::new(
            vec![2, 8, 8],
            vec![
                layer(c1, p[0]),
                Layer { op: pool, neurons: None, recurrent: None, recurrent_bias: None },
                layer(c2, p[1]),
                layer(d, p[2]),
            ],
        )
        .unwrap()
    }
}
