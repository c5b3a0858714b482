#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid network: {0}")]
    Network(String),
    #[error("invalid input: {0}")]
    Input(String),
    #[error("{}: {what}", path.display())]
    Model { path: std::path::PathBuf, what: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
