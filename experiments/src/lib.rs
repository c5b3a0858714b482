//! The experiments, callable from Rust: simulated datasets ([`datasets`]: character windows from
//! scans), the evaluation protocols and their scoring ([`scoring`], [`tactile`], [`chars`],
//! [`words`], [`labeling`]), a simulated taxel dataset ([`taxels`]), SNN recipes and training
//! ([`recipe`], [`train`]), the engine's benchmark ([`mod@bench`]) and each report part as data
//! ([`reports`]). The `braille` binary maps its arguments to these functions, prints what they
//! return and draws it.
//!
//! Everything here that runs on simulated scans is SIMULATED data and says so in what it returns.

pub mod baselines;
pub mod bench;
pub mod calibrate;
pub mod chars;
pub mod datasets;
pub mod error;
pub mod labeling;
pub mod model_bench;
pub mod recipe;
pub mod reports;
pub mod robustness;
pub mod scans;
pub mod scoring;
pub mod search;
pub mod tactile;
pub mod taxels;
pub mod train;
pub mod words;

pub use error::{Error, Result};

/// Progress of a long step, for a caller that shows it (the binary draws bars; a library caller
/// passes `&()` for none). Called from several threads.
pub trait Progress: Sync {
    /// A step of `len` units begins.
    fn start(&self, _what: &str, _len: u64) {}
    /// One unit is done.
    fn inc(&self) {}
    /// The step is done.
    fn finish(&self) {}
    /// A line worth showing as it happens (an intermediate result).
    fn note(&self, _line: &str) {}
}

impl Progress for () {}

/// Peak resident memory of this process (Linux), in MB.
/// Starts a new peak for [`peak_rss_mb`] (Linux: `/proc/self/clear_refs`); whether it could.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Writes `value` as pretty JSON to `path` atomically; an existing file is kept unless `force`.
pub fn write_json(path: &std::path::Path, value: &impl serde::Serialize, force: bool) -> Result<()> {
    use std::io::Write;
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let mut f = encoders::formats::AtomicFile::create(path, force)?;
    serde_json::to_writer_pretty(&mut f, value).map_err(|source| Error::Json { path: path.to_path_buf(), source })?;
    f.write_all(b"\n").map_err(io)?;
    f.commit()?;
    Ok(())
}
