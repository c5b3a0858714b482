//! Words out: from an event stream to labelled character windows (the paper's labeling
//! pipeline, [`labeling`]). Segmentation, the classifiers behind one interface, the temporal word
//! filter and spelling come next.

pub mod error;
pub mod labeling;

pub use error::{Error, Result};
