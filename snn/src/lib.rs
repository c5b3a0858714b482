//! Spiking neural networks: neuron models ([`neuron`]), networks of dense, convolution and
//! pooling layers with a time-stepped reference ([`network`]), and the event-driven engine
//! ([`engine`]) that processes input events one at a time.
//!
//! ```
//! use snn::engine::{Engine, Mode};
//! use snn::network::{Layer, Network, Op};
//! use snn::neuron::NeuronParams;
//!
//! // 2 inputs -> 1 LIF neuron (beta 0.9, threshold 1).
//! let dense = Op::Dense { n_in: 2, n_out: 1, weight: vec![0.6, 0.6], bias: None };
//! let net = Network::new(vec![2], vec![Layer { op: dense, neurons: Some(NeuronParams::lif(0.9)), recurrent: None, recurrent_bias: None }]).unwrap();
//! let engine = Engine::new(&net, 1_000, Mode::Stepped).unwrap();
//! let mut stream = engine.state(0);
//! engine.push(&mut stream, 100, 0, 1.0).unwrap(); // step 0: 0.6
//! engine.push(&mut stream, 1_200, 1, 1.0).unwrap(); // step 1: 0.9 * 0.6 + 0.6 = 1.14 > 1
//! engine.finish(&mut stream, 2_000);
//! assert_eq!(stream.output, vec![(1_000, 0)]);
//! assert_eq!(stream.stats.synops, 2);
//! ```

pub mod chip;
pub mod energy;
pub mod engine;
pub mod error;
pub mod model_file;
pub mod network;
pub mod neuron;
pub mod nir;
pub mod scoring;
pub mod sliding;
pub mod spec;

pub use error::{Error, Result};
