//! Networks that learn, and what a reader keeps of them.
//!
//! Always (no burn, no trainer): the labelled data the trainers learn from ([`data`]), the
//! ResNet's configuration and its inference with batch norm folded ([`resnet::folded`], which
//! reads a model file's tensors).
//!
//! With the `train` feature (default on): the SNN's sparse trainer (`sparse`: backpropagation
//! through time with surrogate gradients on spike lists, our own); dense networks on burn (CPU
//! `flex` backend, autodiff): the ResNet as a burn module and its training, the SNN's
//! time-stepped twin (`snn`), the sparse trainer's reference, and the training loop that runs
//! either (`train`). Trained SNNs leave as [`::snn::network::Network`]s for the event-driven
//! engine. Readers depend on this crate with `default-features = false` and compile neither burn
//! nor the trainer.

pub mod data;
pub mod error;
pub mod resnet;
#[cfg(feature = "train")]
pub mod snn;
#[cfg(feature = "train")]
pub mod temporal;
#[cfg(feature = "train")]
pub mod train;

#[cfg(feature = "train")]
pub mod sparse;

pub use error::{Error, Result};

/// Each row's class of highest logit, of logits `[batch, classes]`.
#[cfg(feature = "train")]
pub(crate) fn predicted_classes(logits: &burn::tensor::Tensor<2>) -> Vec<usize> {
    logits
        .clone()
        .argmax(1)
        .to_data()
        .convert::<i64>()
        .try_into_vec::<i64>()
        .expect("int predictions")
        .into_iter()
        .map(|p| p as usize)
        .collect()
}
