#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid network: {0}")]
    Network(String),
    #[error("invalid input: {0}")]
    Input(String),
    #[error("{}: {what}", path.display())]
    Model { path: std::path::PathBuf, what: String },
    #[error("{}: {source}", path.display())]
    Io { path: std::path::PathBuf, source: std::io::Error },
    #[error("{}: {source}", path.display())]
    Safetensors { path: std::path::PathBuf, source: Box<safetensors::SafeTensorError> },
    /// Writing a file (the atomic writer's errors name the file).
    #[error(transparent)]
    Encoders(Box<encoders::Error>),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<encoders::Error> for Error {
    fn from(e: encoders::Error) -> Self {
        Error::Encoders(Box::new(e))
    }
}
