#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid configuration: {0}")]
    Config(String),
    #[error(transparent)]
    Encoders(#[from] encoders::Error),
    #[error(transparent)]
    Sim(#[from] sim::Error),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
