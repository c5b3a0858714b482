//! The virtual Evetac from Python: one scan of a board row, SIMULATED.

use crate::errors::{OrPy, choice, to_python};
use crate::events::{TonicEvent, resolution_of, to_array, tonic_events};
use corpus::scans::Scanner;
use encoders::Resolution;
use numpy::{PyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use sim::{BoardKind, Direction, Realism};

/// A simulated scan: the events and the simulator's ground truth (for labelling and scoring only;
/// a reader gets the events alone).
#[pyclass(frozen, get_all, module = "neurobraille")]
pub struct Scan {
    /// The events, `EVENTS_DTYPE`, in time order.
    events: Py<PyArray1<TonicEvent>>,
    /// The scan's ground truth as `braille simulate` writes it (`*.truth.json`): the row's text,
    /// the scan's settings, each character's position and time under the sensor, and more.
    truth: Py<PyAny>,
    /// The row's text.
    text: String,
    /// The sensor's `(width, height)`.
    resolution: (u16, u16),
    /// The slide's length in seconds.
    duration_s: f64,
}

#[pymethods]
impl Scan {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "Scan(text={:?}, events={}, duration_s={:.2}, resolution={:?}, SIMULATED)",
            self.text,
            self.events.bind(py).len(),
            self.duration_s,
            self.resolution
        )
    }
}

/// Simulates one scan of `row` of `board` ("SAB", "UN", "RAB", "VAL", "EV", or "text:ANY WORDS"
/// with `/` starting a new row) by the virtual Evetac sliding at `speed_mm_s` at `depth_mm`
/// below first contact, as `braille simulate` does. The same arguments give the same scan:
/// `seed` and `trial` draw the scan's misalignment, speed ripple and noise, `board_seed` the
/// printed board's tolerances [default: derived from the board's name], `sensor_seed` the sensor
/// build. `realism`: "nominal" (the default, as `braille simulate`'s), "clean" or "harsh"
/// (docs/simulator.md). The result is SIMULATED data.
#[pyfunction]
#[pyo3(signature = (board="EV", row=0, speed_mm_s=8.0, depth_mm=1.5, seed=0, trial=0, board_seed=None, sensor_seed=1, realism="nominal", direction="forward", resolution=None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    board: &str,
    row: usize,
    speed_mm_s: f64,
    depth_mm: f64,
    seed: u64,
    trial: u64,
    board_seed: Option<u64>,
    sensor_seed: u64,
    realism: &str,
    direction: &str,
    resolution: Option<Vec<i64>>,
) -> PyResult<Scan> {
    let kind: BoardKind = board.parse().map_err(|e| PyValueError::new_err(format!("board: {e}")))?;
    let realism: Realism = choice("realism", realism)?;
    let direction: Direction = choice("direction", direction)?;
    let resolution = resolution_of("resolution", resolution)?.unwrap_or(Resolution::DVXPLORER);
    if !(speed_mm_s.is_finite() && speed_mm_s > 0.0) {
        return Err(PyValueError::new_err(format!("speed_mm_s must be positive, got {speed_mm_s}")));
    }
    let scan = py
        .detach(|| {
            Scanner::new(kind, board_seed, sensor_seed, realism, resolution, speed_mm_s, depth_mm, direction, seed)?
                .scan(row, trial)
        })
        .or_py()?;
    Ok(Scan {
        events: to_array(py, tonic_events(&scan.events)).unbind(),
        truth: to_python(py, &scan.truth)?.unbind(),
        text: scan.truth.row_text.clone(),
        resolution: (resolution.width, resolution.height),
        duration_s: scan.truth.timeline.end_s,
    })
}
