//! Words out: everything a deployed reader needs. From an event stream to character windows (the
//! paper's labeling pipeline, [`labeling`]), a window to a network's input ([`input`],
//! [`preprocess`]), trained models loaded by the architecture their header names ([`models`], with
//! typed headers) and run on windows ([`classify`]: a loaded model is shared, each stream owns its
//! state), the streaming reader ([`reader`]) and a whole source read with bounded memory
//! ([`source`]), the temporal filter ([`words`]), spelling ([`spelling`], [`lexicon`]), every
//! shipped model named in one place ([`shipped`]), any SNN or NIR graph run on events
//! ([`network`]), and the Braille codes from print to cells and back ([`code`]: the paper's
//! letters, Unified English Braille grades 1 and 2 through liblouis's tables; words of cells read
//! back to print in [`cell_spell`]; cells of one dot column placed on the print's grid in
//! [`grid`]).
//!
//! Reading needs no training code and no simulator: this crate builds on `encoders`, `snn` and
//! `learn` without its `train` feature (burn's inference only).

pub mod abstain;
pub mod cell_spell;
pub mod classify;
pub mod code;
pub mod error;
pub mod grid;
pub mod input;
pub mod labeling;
pub mod lexicon;
pub mod models;
pub mod network;
pub mod preprocess;
pub mod reader;
pub mod shipped;
pub mod source;
pub mod speed;
pub mod spelling;
pub mod words;

pub use error::{Error, Result};
