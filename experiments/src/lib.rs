//! The experiments, callable from Rust, by job: training ([`train`]: SNN recipes, fitting, the
//! validation-driven search, the linear baselines, the ResNet's training), evaluation ([`eval`]:
//! one scoring module and every protocol: characters, words, tactile datasets, the labeler, the
//! reader's calibration, robustness), benchmarks ([`mod@bench`]) and each report part as data
//! ([`reports`]). The data they run on comes from `corpus`; the reader they evaluate from
//! `pipeline`. The `braille` binary maps its arguments to these functions, prints what they
//! return and draws it.
//!
//! Everything here that runs on simulated scans is SIMULATED data and says so in what it returns.

pub mod bench;
pub mod demo;
pub mod error;
pub mod eval;
pub mod reports;
pub mod sealed;
pub mod train;

pub use error::{Error, Result};

pub use corpus::{Progress, write_json};
pub use pipeline::source::{peak_rss_mb, reset_peak_rss};
