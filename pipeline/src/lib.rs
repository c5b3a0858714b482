//! Words out: from an event stream to character windows (the paper's labeling pipeline,
//! [`labeling`]), a window to a network's input ([`input`], [`augment`]), trained models loaded by
//! the architecture their header names ([`models`]) and run on windows ([`classify`]: a loaded
//! model is shared, each stream owns its state), the streaming reader ([`reader`]), the temporal
//! filter ([`words`]) and spelling ([`spelling`], [`lexicon`]).
//!
//! Reading needs no training code and no simulator: this crate builds on `encoders`, `snn` and
//! `learn` without its `train` feature (burn's inference only).

pub mod augment;
pub mod classify;
pub mod error;
pub mod input;
pub mod labeling;
pub mod lexicon;
pub mod models;
pub mod reader;
pub mod speed;
pub mod spelling;
pub mod words;

pub use error::{Error, Result};
