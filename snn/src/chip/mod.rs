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

pub mod xylo;

use serde::{Deserialize, Serialize};

/// A chip whose arithmetic the engine models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Chip {
    /// SynSense Xylo Audio 2 (SYNS61201).
    Xylo,
}

impl Chip {
    pub const ALL: [Chip; 1] = [Chip::Xylo];

    pub fn name(self) -> &'static str {
        match self {
            Chip::Xylo => "Xylo",
        }
    }

    /// The chip's number formats.
    pub fn format(self) -> NumberFormat {
        match self {
            Chip::Xylo => xylo::FORMAT,
        }
    }

    /// The neurons nearest `p` that the chip computes as they are: its decays, its reset (what
    /// a network trained for the chip uses).
    pub fn neurons(self, p: crate::neuron::NeuronParams) -> crate::neuron::NeuronParams {
        match self {
            Chip::Xylo => xylo::neurons(p),
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
}

/// What a neuron does after it spikes, in the chip.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ChipReset {
    /// The threshold is subtracted once per spike, several spikes per step allowed.
    Subtract,
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
    /// Spikes a hidden neuron may send in one step.
    pub max_spikes_per_step: u8,
    /// Spikes an output neuron may send in one step.
    pub max_output_spikes_per_step: u8,
    /// Input events per channel and step the chip takes (more are dropped).
    pub max_input_events_per_step: u8,
    /// Where these figures come from.
    pub source: &'static str,
}
