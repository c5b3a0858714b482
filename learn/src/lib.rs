//! Training. The SNN's sparse trainer ([`sparse`]: backpropagation through time with surrogate
//! gradients on spike lists, our own, without burn); dense-tensor networks on burn (CPU `flex`
//! backend): the paper's ResNet baseline ([`resnet`]: inference always, training with the `train`
//! feature), and with `train` the SNN's time-stepped twin ([`snn`]), the sparse trainer's
//! reference, and the training loop that runs either ([`train`]); the labelled spike trains they
//! learn from ([`data`]). Trained SNNs leave as [`::snn::network::Network`]s for the event-driven
//! engine.
//!
//! Without the `train` feature (default on) burn's autodiff and optimisers are not compiled:
//! readers that only run a trained ResNet depend on this crate with `default-features = false`.

pub mod data;
pub mod error;
pub mod resnet;
#[cfg(feature = "train")]
pub mod snn;
#[cfg(feature = "train")]
pub mod temporal;
#[cfg(feature = "train")]
pub mod train;

pub mod sparse;

pub use error::{Error, Result};

/// Each row's class of highest logit, of logits `[batch, classes]`.
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
