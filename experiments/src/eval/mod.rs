//! Evaluation: one scoring module used by every protocol ([`scoring`]), character classifiers on
//! simulated windows ([`chars`]), word reading on simulated scans ([`words`]), SNNs on tactile
//! dataset folders ([`tactile`]), the labeler against the truth ([`labeling`]), the reader's
//! operating point chosen on validation words ([`calibrate`]), one nuisance at a time
//! ([`robustness`]), a Braille code against liblouis's own test cases ([`braille_spec`]) and the
//! UEB readers on print boards ([`ueb`]).

pub mod braille_spec;
pub mod calibrate;
pub mod chars;
pub mod chip;
pub mod labeling;
pub mod robustness;
pub mod robustness_words;
pub mod scoring;
pub mod tactile;
pub mod ueb;
pub mod words;
