//! The crate's errors, with their sources kept.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Arguments or data that do not fit the protocol.
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Encoders(#[from] encoders::Error),
    #[error(transparent)]
    Sim(#[from] sim::Error),
    #[error(transparent)]
    Snn(#[from] snn::Error),
    #[error(transparent)]
    Learn(#[from] learn::Error),
    /// Boxed: the reader's errors carry their sources, which makes them large.
    #[error(transparent)]
    Pipeline(Box<pipeline::Error>),
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
