#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A network that cannot be built or run as given; `layer` names the layer at fault.
    #[error("invalid network: {}{what}", layer.map_or(String::new(), |k| format!("layer {k}: ")))]
    Network { layer: Option<usize>, what: String },
    /// A network a chip's number formats cannot hold, and why; `layer` names the layer at fault.
    #[error("{chip}: {}{what}", layer.map_or(String::new(), |k| format!("layer {k}: ")))]
    Chip { chip: crate::chip::Chip, layer: Option<usize>, what: String },
    /// Input that does not fit the network or the stream (an input index, a time, a length).
    #[error("invalid input: {what}")]
    Input { what: String },
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

impl Error {
    /// A network fault not tied to one layer.
    pub fn network(what: impl Into<String>) -> Error {
        Error::Network { layer: None, what: what.into() }
    }

    /// A fault of layer `k`.
    pub fn layer(k: usize, what: impl Into<String>) -> Error {
        Error::Network { layer: Some(k), what: what.into() }
    }

    /// Input that does not fit.
    pub fn input(what: impl Into<String>) -> Error {
        Error::Input { what: what.into() }
    }
}

impl From<encoders::Error> for Error {
    fn from(e: encoders::Error) -> Self {
        Error::Encoders(Box::new(e))
    }
}
