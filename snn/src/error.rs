#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid network: {0}")]
    Network(String),
    #[error("invalid input: {0}")]
    Input(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
