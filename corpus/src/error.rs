//! The crate's errors: what was wrong, where, and what was expected; sources kept.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A board the command line named that cannot be printed.
    #[error("board {board:?}: {what}")]
    Board { board: String, what: String },
    /// A setting outside what it can be.
    #[error("{name} = {value}: expected {expected}")]
    Setting { name: &'static str, value: String, expected: &'static str },
    /// A board row that the board does not have.
    #[error("row {row}: the board has {rows} rows (0..{})", rows.saturating_sub(1))]
    NoSuchRow { row: usize, rows: usize },
    /// Several scans asked to be written to one event file.
    #[error("{}: {scans} scans (rows x trials) need a folder, not a file", path.display())]
    NotAFolder { path: PathBuf, scans: usize },
    /// Windows asked for no model input.
    #[error("no model input to build windows for")]
    NoInputs,
    /// Windows asked for inputs whose labelers differ.
    #[error("the models label their windows differently; build their windows separately")]
    LabelersDiffer,
    /// Boxed, as the other large sources: a small `Result` on every path.
    #[error(transparent)]
    Encoders(Box<encoders::Error>),
    #[error(transparent)]
    Sim(#[from] sim::Error),
    #[error(transparent)]
    Pipeline(Box<pipeline::Error>),
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{}: {source}", path.display())]
    Json { path: PathBuf, source: serde_json::Error },
    #[error(transparent)]
    Recordings(Box<crate::recordings::Error>),
    /// Something wrong with one recorded scan, named by its file.
    #[error("{}: {source}", path.display())]
    Scan { path: PathBuf, source: Box<Error> },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// This error, named by the recorded scan `path` it happened in.
    pub fn in_file(self, path: &std::path::Path) -> Error {
        Error::Scan { path: path.to_path_buf(), source: Box::new(self) }
    }
}

impl From<pipeline::Error> for Error {
    fn from(e: pipeline::Error) -> Self {
        Error::Pipeline(Box::new(e))
    }
}

impl From<encoders::Error> for Error {
    fn from(e: encoders::Error) -> Self {
        Error::Encoders(Box::new(e))
    }
}

impl From<crate::recordings::Error> for Error {
    fn from(e: crate::recordings::Error) -> Self {
        Error::Recordings(Box::new(e))
    }
}
