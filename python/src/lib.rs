//! The `neurobraille` Python module (`neurobraille._braille`, re-exported by `neurobraille/__init__.py`).
//!
//! Everything here is a thin layer over the Rust crates: event files ([`encoders`]), the
//! event-driven engine and NIR ([`snn`], [`pipeline::network`]), the virtual Evetac
//! ([`corpus::scans`]), a lab's recordings folder ([`corpus::recordings`]) and the word reader
//! ([`pipeline`]). Events cross the boundary as NumPy
//! structured arrays with Tonic's fields `x, y, t, p`; work runs with the GIL released; every Rust
//! error arrives as a Python exception carrying the same message.

// The libraries' error types are what they are; their size does not matter at this boundary.
#![allow(clippy::result_large_err)]

use pyo3::prelude::*;

mod errors;
mod events;
mod network;
mod reader;
mod recordings;
mod simulate;

#[pymodule]
fn _braille(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("BrailleError", py.get_type::<errors::BrailleError>())?;
    m.add("EVENTS_DTYPE", events::events_dtype(py))?;
    m.add_function(wrap_pyfunction!(events::read_events, m)?)?;
    m.add_function(wrap_pyfunction!(events::write_events, m)?)?;
    m.add_function(wrap_pyfunction!(events::iter_events, m)?)?;
    m.add_function(wrap_pyfunction!(events::event_file_info, m)?)?;
    m.add_class::<events::EventFileReader>()?;
    m.add_class::<network::Network>()?;
    m.add_class::<network::RunResult>()?;
    m.add_function(wrap_pyfunction!(network::peer_benchmark, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_class::<simulate::Scan>()?;
    m.add_class::<reader::Reader>()?;
    m.add_class::<reader::WordStream>()?;
    m.add_class::<reader::Word>()?;
    m.add_class::<recordings::Recordings>()?;
    m.add_class::<recordings::Recording>()?;
    Ok(())
}
