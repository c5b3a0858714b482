/// What can go wrong when a board, a sensor or a scan is set up.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter outside the range the physics allows.
    #[error("simulator parameter `{name}` = {value} is out of range: {expected}")]
    OutOfRange { name: &'static str, value: String, expected: &'static str },
    /// Parameters that are each in range but do not fit together: which, and why.
    #[error("simulator parameters {names} do not fit together: {why}")]
    Inconsistent { names: &'static str, why: String },
    #[error("no Braille cell for {0:?}")]
    NoCell(char),
    #[error("row {row} does not exist: the board has {rows} rows")]
    NoRow { row: usize, rows: usize },
    #[error("row {row} ({text:?}) needs {needed_mm:.1} mm but the row has {usable_mm:.1} mm between its margins")]
    RowTooLong { row: usize, text: String, needed_mm: f64, usable_mm: f64 },
    /// A random distribution refused its parameters (they are validated first, so this is a bug).
    #[error("the distribution of `{name}` cannot be drawn")]
    Distribution {
        name: &'static str,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

impl Error {
    pub(crate) fn out_of_range(name: &'static str, value: impl std::fmt::Display, expected: &'static str) -> Error {
        Error::OutOfRange { name, value: value.to_string(), expected }
    }

    pub(crate) fn distribution(name: &'static str) -> impl FnOnce(rand_distr::NormalError) -> Error {
        move |e| Error::Distribution { name, source: Box::new(e) }
    }
}

/// Checks that `value` lies in `range`; names the parameter otherwise.
pub(crate) fn check<T: PartialOrd + std::fmt::Display>(
    name: &'static str,
    value: T,
    range: impl std::ops::RangeBounds<T>,
    expected: &'static str,
) -> Result<()> {
    if range.contains(&value) { Ok(()) } else { Err(Error::out_of_range(name, value, expected)) }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
