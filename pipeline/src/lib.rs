//! Words out: from an event stream to labelled character windows (the paper's labeling
//! pipeline, [`labeling`]), from per-frame detections to words (the temporal filter,
//! [`words`]), spelling correction ([`spelling`]) and the paper's word metrics ([`metrics`]).
//! The segmentation network and the classifiers behind one interface come next.

pub mod augment;
pub mod chars;
pub mod classify;
pub mod error;
pub mod input;
pub mod labeling;
pub mod lexicon;
pub mod metrics;
pub mod reader;
pub mod spelling;
pub mod words;

pub use error::{Error, Result};
