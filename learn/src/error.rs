//! The crate's errors, with their sources kept.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Tensors that do not fit a model's configuration.
    #[error("{0}")]
    Tensors(String),
    /// burn's tensor store (its error type is not `std::error::Error`, so it comes as text).
    #[error("tensor store: {0}")]
    Store(String),
    #[error(transparent)]
    Safetensors(#[from] safetensors::SafeTensorError),
    #[error(transparent)]
    Snn(#[from] snn::Error),
    #[error(transparent)]
    Encoders(#[from] encoders::Error),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
