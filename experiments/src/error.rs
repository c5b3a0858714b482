//! The crate's errors, with their sources kept.

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A setting outside what it can be: its name, the value given, what it must be.
    #[error("{name} = {value}: expected {expected}")]
    Setting { name: &'static str, value: String, expected: &'static str },
    /// Options that do not go together, and why.
    #[error("{0}")]
    Options(String),
    /// A dataset folder that cannot serve the protocol asked of it.
    #[error("{}: {what}", path.display())]
    Data { path: std::path::PathBuf, what: String },
    /// A model file that cannot serve the protocol asked of it (another encoding, step or input).
    #[error("{}: {what}", path.display())]
    Model { path: std::path::PathBuf, what: String },
    /// A training setting's key (`--set key=value`) that names no field, or a value its field
    /// does not take: the key, the value, and what is wrong (serde's words, with the type expected).
    #[error("key `{key}` = `{value}`: {what}")]
    Key { key: String, value: String, what: String },
    /// A recipe that is neither a preset nor a file.
    #[error("recipe `{name}`: neither a preset ({presets}) nor a file")]
    UnknownRecipe { name: String, presets: String },
    /// A line of a search log that does not hold a trial of this dataset.
    #[error("{} line {line}: {what}", path.display())]
    TrialLine { path: std::path::PathBuf, line: usize, what: String },
    /// Ridge regression's normal equations with no solution.
    #[error("ridge regression: the system with alpha {alpha} is singular")]
    Singular { alpha: f64 },
    /// The engine refused a network or an input (`what` names which: a model, a sample).
    #[error("{what}: {source}{hint}")]
    Engine { what: String, source: snn::Error, hint: &'static str },
    /// A part of the whole report that failed.
    #[error("report part `{part}`")]
    ReportPart { part: &'static str, source: Box<Error> },
    /// A calibration file whose chosen operating point is out of range.
    #[error("{}: `chosen`: {source}", path.display())]
    Chosen { path: std::path::PathBuf, source: Box<pipeline::Error> },
    /// A figure that could not be drawn or written.
    #[error("{}: {what}", path.display())]
    Figure { path: std::path::PathBuf, what: String },
    /// Models that were to be scored on the same windows were not.
    #[error("the models saw different window counts ({counts:?})")]
    WindowCounts { counts: Vec<usize> },
    /// A file that would be replaced without `force`.
    #[error("{}: exists; pass --force to replace it", path.display())]
    Exists { path: std::path::PathBuf },
    /// A search folder whose logs cannot serve this search.
    #[error("{}: {what}", dir.display())]
    SearchLog { dir: std::path::PathBuf, what: String },
    /// A member of an ensemble that differs from the first in what the members must share.
    #[error("{}: another {what} than {}", path.display(), first.display())]
    EnsembleMember { path: std::path::PathBuf, first: std::path::PathBuf, what: &'static str },
    /// Boxed, as the other large sources: a small `Result` on every path.
    #[error(transparent)]
    Encoders(Box<encoders::Error>),
    #[error(transparent)]
    Sim(#[from] sim::Error),
    #[error(transparent)]
    Snn(#[from] snn::Error),
    #[error(transparent)]
    Learn(#[from] learn::Error),
    /// Boxed: the reader's errors carry their sources, which makes them large.
    #[error(transparent)]
    Pipeline(Box<pipeline::Error>),
    /// Boxed: the corpus's errors carry the reader's.
    #[error(transparent)]
    Corpus(Box<corpus::Error>),
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

impl From<encoders::Error> for Error {
    fn from(e: encoders::Error) -> Self {
        Error::Encoders(Box::new(e))
    }
}

impl From<corpus::Error> for Error {
    fn from(e: corpus::Error) -> Self {
        Error::Corpus(Box::new(e))
    }
}

impl From<corpus::recordings::Error> for Error {
    fn from(e: corpus::recordings::Error) -> Self {
        Error::Corpus(Box::new(e.into()))
    }
}
