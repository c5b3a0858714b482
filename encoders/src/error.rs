//! Errors of the event crate: every one names the file and the place in it.

use std::fmt;
use std::path::PathBuf;

/// Where in a file something went wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A byte offset from the start of the file.
    Byte(u64),
    /// A 1-based line number in a text file.
    Line(u64),
    /// The `index`-th event (0-based) of the packet that starts at byte `packet_offset`.
    PacketEvent { packet_offset: u64, index: usize },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Byte(b) => write!(f, "byte {b}"),
            Location::Line(l) => write!(f, "line {l}"),
            Location::PacketEvent { packet_offset, index } => {
                write!(f, "event {index} of the packet at byte {packet_offset}")
            }
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },

    #[error("{path}: at {at}: not an {format} file: expected {expected}, found {found}")]
    BadMagic { path: PathBuf, at: Location, format: &'static str, expected: String, found: String },

    #[error("{path}: truncated at {at}: expected {expected}")]
    Truncated { path: PathBuf, at: Location, expected: String },

    #[error("{path}: at {at}: unknown compression {value} (supported: 0 none, 1 LZ4, 2 LZ4 high, 3 ZSTD, 4 ZSTD high)")]
    UnknownCompression { path: PathBuf, at: Location, value: i64 },

    #[error("{path}: at {at}: {what} claims {size} bytes, more than the limit of {limit} bytes")]
    TooLarge { path: PathBuf, at: Location, what: &'static str, size: u64, limit: u64 },

    #[error("{path}: at {at}: {what}")]
    Corrupt { path: PathBuf, at: Location, what: String },

    #[error("{path}: at {at}: timestamp {t_us} us goes backwards (previous event at {previous_us} us)")]
    TimestampBackwards { path: PathBuf, at: Location, t_us: i64, previous_us: i64 },

    #[error("{path}: at {at}: coordinates ({x}, {y}) outside the declared resolution {width}x{height}")]
    OutOfRange { path: PathBuf, at: Location, x: i64, y: i64, width: u16, height: u16 },

    #[error("{path}: at {at}: field `{field}`: expected {expected}, found {found:?}")]
    Parse { path: PathBuf, at: Location, field: String, expected: String, found: String },

    #[error("{path}: empty file: expected {expected}")]
    Empty { path: PathBuf, expected: String },

    #[error("{path}: {what}")]
    Unsupported { path: PathBuf, what: String },

    #[error("{path}: exists, and is replaced only when asked (--force on the command line, overwrite=True in Python)")]
    Exists { path: PathBuf },

    /// A setting outside what it can be: which setting, and what is wrong with the value given.
    #[error("invalid {setting}: {what}")]
    Config { setting: &'static str, what: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// Setting `setting` with a value that is not allowed.
    pub fn config(setting: &'static str, what: impl Into<String>) -> Error {
        Error::Config { setting, what: what.into() }
    }
}

/// Maps an I/O error on `path` to [`Error::Io`], or to [`Error::Truncated`] for an unexpected end.
pub(crate) fn io_at(path: &std::path::Path, at: Location, expected: &str, e: std::io::Error) -> Error {
    if e.kind() == std::io::ErrorKind::UnexpectedEof {
        Error::Truncated { path: path.to_path_buf(), at, expected: expected.to_string() }
    } else {
        Error::Io { path: path.to_path_buf(), source: e }
    }
}
