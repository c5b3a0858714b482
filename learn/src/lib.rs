//! Dense-tensor training on burn (CPU `flex` backend with autodiff): the SNN's time-stepped twin
//! trained by backpropagation through time with surrogate gradients ([`snn`], [`train`]), and the
//! labelled spike trains it learns from ([`data`]). Trained SNNs leave as [`::snn::network::Network`]s
//! for the event-driven engine.

pub mod data;
pub mod resnet;
pub mod snn;
pub mod train;
