//! The crate's errors: what was wrong, where, and what was expected; sources kept.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A setting outside what it can be.
    #[error("{name} = {value}: expected {expected}")]
    Setting { name: &'static str, value: String, expected: &'static str },
    /// Events that break the stream's contract (time order, the sensor's shape).
    #[error("event {index} at {t_us} us goes back in time (the previous was at {previous_t_us} us)")]
    OutOfOrder { index: u64, t_us: i64, previous_t_us: i64 },
    /// A window or state handed to a model it does not belong to.
    #[error("{what}")]
    Mismatch { what: &'static str },
    /// A window whose shape does not fit the model's input.
    #[error(
        "a window of {bins} bins x {height}x{width} does not fit the model's input (rows {rows:?}, columns {cols:?}, {frames} bins)"
    )]
    WindowShape {
        bins: usize,
        height: usize,
        width: usize,
        rows: std::ops::Range<usize>,
        cols: std::ops::Range<usize>,
        frames: usize,
    },
    #[error("the model's input band (rows {band:?}) does not fit its crop (rows {rows:?}): {reason}")]
    Band { band: std::ops::Range<usize>, rows: std::ops::Range<usize>, reason: &'static str },
    /// Boxed, as the other large sources: a small `Result` on every path.
    #[error(transparent)]
    Encoders(Box<encoders::Error>),
    #[error(transparent)]
    Snn(Box<snn::Error>),
    #[error(transparent)]
    Learn(Box<learn::Error>),
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A model file whose header does not fit what reads it.
    #[error("{}: {what}", path.display())]
    Model { path: PathBuf, what: String },
    /// A header key of a model file that does not hold what it must.
    #[error("{}: header `{key}`: expected {expected}, found {found}", path.display())]
    Header { path: PathBuf, key: &'static str, expected: &'static str, found: String },
    /// A network whose input is not a camera's (`[C, H, W]` with one or two channels, or flat).
    #[error("{}: an input of shape {shape:?} takes no camera events (1 channel: polarities merged, 2: OFF and ON)", path.display())]
    NotCameraInput { path: PathBuf, shape: Vec<usize> },
    /// A flat input that is neither two planes nor one of the file's sensor.
    #[error("{}: the network's {inputs} inputs are neither 2 x {height} x {width} nor {height} x {width} of the file's {width} x {height} sensor", path.display())]
    InputsDontFitSensor { path: PathBuf, inputs: usize, width: u16, height: u16 },
    #[error("{}: event {index} (t {t_us} us, x {x}, y {y}) lies outside the network's input of {width} x {height} (width x height)", path.display())]
    EventOutsideInput { path: PathBuf, index: u64, t_us: i64, x: u16, y: u16, width: usize, height: usize },
    #[error("{}: event {index} at {t_us} us is before time 0", path.display())]
    EventBeforeZero { path: PathBuf, index: u64, t_us: i64 },
    /// The event-driven engine and the time-stepped reference disagree on a run's output spikes.
    #[error("{}: the engine's output spikes differ from the time-stepped reference ({engine_spikes} against {reference_spikes})", path.display())]
    EngineDisagrees { path: PathBuf, engine_spikes: usize, reference_spikes: usize },
    /// An event source that failed while it was read.
    #[error("reading {name}")]
    Read { name: String, source: Box<encoders::Error> },
    /// A vendored Braille table that did not compile (a build fault, not the user's input).
    #[error("Braille table {table}: {what}")]
    BrailleTable { table: String, what: String },
    /// Print a Braille code cannot write.
    #[error("{code} cannot write {character:?} (character {index} of {text:?})")]
    Untranslatable { code: crate::code::BrailleCode, text: String, index: usize, character: char },
    /// Braille text holding a character that is no six-dot cell.
    #[error("character {index}, {character:?}, is not a six-dot Braille cell (U+2800-U+283F) or a space")]
    NotBraille { index: usize, character: char },
    /// A stream the reader refused (events out of order, outside the sensor).
    #[error("{name}")]
    Source { name: String, source: Box<Error> },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<encoders::Error> for Error {
    fn from(e: encoders::Error) -> Self {
        Error::Encoders(Box::new(e))
    }
}

impl From<snn::Error> for Error {
    fn from(e: snn::Error) -> Self {
        Error::Snn(Box::new(e))
    }
}

impl From<learn::Error> for Error {
    fn from(e: learn::Error) -> Self {
        Error::Learn(Box::new(e))
    }
}
