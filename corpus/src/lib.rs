//! Data in: the SIMULATED corpora the readers are trained, validated and tested on, and their
//! files. The simulated world of a protocol ([`world`]: realism preset, sensor builds, seeds),
//! its boards ([`boards`]: training, validation and unseen word rows), labelled character windows
//! cut from scans by the paper's labeling pipeline ([`windows`]), scans written as event files
//! with their truth ([`scans`]) and tactile taxel datasets in the iCub layout ([`taxels`]).
//!
//! Everything here is SIMULATED data and says so in what it returns. Nothing here trains or
//! scores: `experiments` does, and the Python package builds on this crate without it.

pub mod boards;
pub mod error;
pub mod recordings;
pub mod scans;
pub mod taxels;
pub mod windows;
pub mod world;

pub use error::{Error, Result};
pub use world::World;

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
