//! The crate's errors, with their sources kept.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Tensors that do not fit a model's configuration: which tensor (if one), and how.
    #[error("{}{what}", tensor.as_ref().map_or(String::new(), |t| format!("tensor `{t}`: ")))]
    Tensors { tensor: Option<String>, what: String },
    /// burn's tensor store, writing (`save`) or reading (`load`): its error type is not
    /// `std::error::Error`, so it comes as text.
    #[error("tensor store ({step}): {what}")]
    Store { step: &'static str, what: String },
    #[error(transparent)]
    Safetensors(#[from] safetensors::SafeTensorError),
    #[error(transparent)]
    Snn(#[from] snn::Error),
    #[error(transparent)]
    Encoders(#[from] encoders::Error),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
