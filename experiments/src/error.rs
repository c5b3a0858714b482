//! The crate's errors, with their sources kept.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Arguments or data that do not fit the protocol.
    #[error("{0}")]
    Invalid(String),
    /// Boxed, as the other large sources: a small `Result` on every path.
    #[error(transparent)]
    Encoders(Box<encoders::Error>),
    #[error(transparent)]
    Sim(#[from] sim::Error),
    #[error(transparent)]
    Snn(#[from] snn::Error),
    #[error(transparent)]
    Learn(#[from] learn::Error),
    /// Boxed: the reader's errors carry their sources, which makes them large.
    #[error(transparent)]
    Pipeline(Box<pipeline::Error>),
    /// An event source that failed while it was read.
    #[error("reading {name}")]
    Read { name: String, source: Box<encoders::Error> },
    /// A stream the reader refused (events out of order, outside the sensor).
    #[error("{name}")]
    Stream { name: String, source: Box<pipeline::Error> },
    #[error(transparent)]
    Fmt(#[from] std::fmt::Error),
    #[error("{}: {source}", path.display())]
    Io { path: std::path::PathBuf, source: std::io::Error },
    #[error("{}: {source}", path.display())]
    Json { path: std::path::PathBuf, source: serde_json::Error },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

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
