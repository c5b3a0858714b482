//! Rust errors as Python exceptions, names as enums, and JSON values as Python objects.

use pyo3::exceptions::{PyFileExistsError, PyFileNotFoundError, PyOSError, PyPermissionError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    neurobraille,
    BrailleError,
    pyo3::exceptions::PyException,
    "An error of the braille library: bad input (naming the file or array and the place), a model that does not fit its input, a network a chip cannot run. The message is the Rust library's."
);

/// The Python exception for a library error, with the library's message: `FileNotFoundError`,
/// `FileExistsError`, `PermissionError` or `OSError` when an I/O error caused it, `BrailleError`
/// otherwise.
pub fn to_py<E: std::error::Error + 'static>(e: E) -> PyErr {
    let msg = e.to_string();
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(&e);
    while let Some(c) = cause {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return match io.kind() {
                std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(msg),
                std::io::ErrorKind::AlreadyExists => PyFileExistsError::new_err(msg),
                std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(msg),
                _ => PyOSError::new_err(msg),
            };
        }
        if let Some(encoders::Error::Exists { .. }) = event_file_error(c) {
            return PyFileExistsError::new_err(msg);
        }
        cause = c.source();
    }
    BrailleError::new_err(msg)
}

/// The event-file error a library error wraps (the wrappers are transparent: their `source` skips
/// the wrapped error itself).
fn event_file_error<'a>(e: &'a (dyn std::error::Error + 'static)) -> Option<&'a encoders::Error> {
    if let Some(e) = e.downcast_ref::<encoders::Error>() {
        return Some(e);
    }
    if let Some(snn::Error::Encoders(e)) = e.downcast_ref::<snn::Error>() {
        return Some(e);
    }
    if let Some(e) = e.downcast_ref::<pipeline::Error>() {
        return match e {
            pipeline::Error::Encoders(e) => Some(e),
            pipeline::Error::Read { source, .. } => Some(&**source),
            pipeline::Error::Snn(e) => event_file_error(&**e),
            pipeline::Error::Source { source, .. } => event_file_error(&**source),
            _ => None,
        };
    }
    match e.downcast_ref::<corpus::Error>()? {
        corpus::Error::Encoders(e) => Some(e),
        corpus::Error::Pipeline(e) => event_file_error(&**e),
        _ => None,
    }
}

/// Maps a library result into a Python one.
pub trait OrPy<T> {
    fn or_py(self) -> PyResult<T>;
}

impl<T, E: std::error::Error + 'static> OrPy<T> for Result<T, E> {
    fn or_py(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}

/// A choice given by name, as the command line names it (`"stepped"`, `"to-v-reset"`), or a
/// `ValueError` listing the names.
pub fn choice<T: clap::ValueEnum>(what: &str, name: &str) -> PyResult<T> {
    T::from_str(name, true).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value())
            .map(|p| p.get_name().to_string())
            .collect();
        PyValueError::new_err(format!("{what}: unknown value {name:?}; one of {}", names.join(", ")))
    })
}

/// The command-line name of a choice.
pub fn name_of<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value().map_or_else(String::new, |p| p.get_name().to_string())
}

/// A serialisable value as plain Python objects (dicts, lists, numbers, strings).
pub fn to_python<'py, T: serde::Serialize + ?Sized>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| BrailleError::new_err(e.to_string()))?;
    py.import("json")?.getattr("loads")?.call1((text,))
}
