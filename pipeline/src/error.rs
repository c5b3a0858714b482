//! The crate's errors, with their sources kept.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid configuration: {0}")]
    Config(String),
    /// Events that break the stream's contract (time order, the sensor's shape).
    #[error("invalid input: {0}")]
    Input(String),
    #[error(transparent)]
    Encoders(#[from] encoders::Error),
    #[error(transparent)]
    Snn(#[from] snn::Error),
    #[error(transparent)]
    Learn(#[from] learn::Error),
    #[error("{}: {source}", path.display())]
    Io {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A model file whose header does not fit what reads it.
    #[error("{}: {what}", path.display())]
    Model { path: std::path::PathBuf, what: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
