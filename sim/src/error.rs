#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid simulator configuration: {0}")]
    Config(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
