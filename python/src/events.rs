//! Event files and NumPy structured arrays with Tonic's fields.
//!
//! Arrays handed out have the dtype `[('x', '<u2'), ('y', '<u2'), ('t', '<i8'), ('p', 'u1')]`
//! (`EVENTS_DTYPE`, what `braille convert` writes to `.npy`): decoded events are laid out once in
//! that layout and the buffer is handed to NumPy without a copy. Arrays taken in may have any
//! integer (or boolean) fields named `x, y, t, p` in any order, as Tonic's datasets do; an array
//! already of `EVENTS_DTYPE` is read in place.

use crate::errors::{BrailleError, OrPy, to_python};
use encoders::formats::{self, EventSource, OpenOptions};
use encoders::{Event, Polarity, Resolution};
use numpy::{Element, PyArray1, PyArrayDescr, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use std::path::{Path, PathBuf};

/// One event as NumPy lays out `EVENTS_DTYPE` (13 bytes, no padding).
#[repr(C, packed)]
#[derive(Debug, Clone, Copy)]
pub struct TonicEvent {
    pub x: u16,
    pub y: u16,
    pub t: i64,
    pub p: u8,
}

impl From<&Event> for TonicEvent {
    #[inline]
    fn from(e: &Event) -> Self {
        TonicEvent { x: e.x, y: e.y, t: e.t_us, p: e.polarity as u8 }
    }
}

impl TonicEvent {
    #[inline]
    pub fn event(self) -> Event {
        let TonicEvent { x, y, t, p } = self;
        Event::new(t, x, y, Polarity::from_on(p != 0))
    }
}

// SAFETY: `TonicEvent` is plain data whose `repr(C, packed)` layout is exactly the dtype returned.
unsafe impl Element for TonicEvent {
    const IS_COPY: bool = true;

    fn get_dtype(py: Python<'_>) -> Bound<'_, PyArrayDescr> {
        static DTYPE: PyOnceLock<Py<PyArrayDescr>> = PyOnceLock::new();
        DTYPE
            .get_or_init(py, || {
                let fields = vec![("x", "<u2"), ("y", "<u2"), ("t", "<i8"), ("p", "u1")];
                PyArrayDescr::new(py, fields).expect("a valid structured dtype").unbind()
            })
            .clone_ref(py)
            .into_bound(py)
    }

    fn clone_ref(&self, _py: Python<'_>) -> Self {
        *self
    }
}

pub fn events_dtype(py: Python<'_>) -> Bound<'_, PyArrayDescr> {
    TonicEvent::get_dtype(py)
}

/// Events as a NumPy array of `EVENTS_DTYPE`, taking the buffer over.
pub fn to_array(py: Python<'_>, events: Vec<TonicEvent>) -> Bound<'_, PyArray1<TonicEvent>> {
    PyArray1::from_vec(py, events)
}

pub fn tonic_events(events: &[Event]) -> Vec<TonicEvent> {
    events.iter().map(TonicEvent::from).collect()
}

/// A sensor size from Python: `(width, height)` or Tonic's `(width, height, polarities)`.
pub fn resolution_of(what: &str, size: Option<Vec<i64>>) -> PyResult<Option<Resolution>> {
    let Some(size) = size else { return Ok(None) };
    match size[..] {
        [w, h] | [w, h, _] if (1..=65535).contains(&w) && (1..=65535).contains(&h) => {
            Ok(Some(Resolution::new(w as u16, h as u16)))
        }
        _ => Err(PyValueError::new_err(format!(
            "{what}: expected (width, height) or Tonic's (width, height, polarities) of 1 to 65535 pixels, got {size:?}"
        ))),
    }
}

/// The events of a NumPy structured array (fields `x, y, t, p`), checked: coordinates in
/// 0..65535, timestamps never going back. `what` names the array in errors.
pub fn events_of(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Event>> {
    let events = if let Ok(a) = obj.cast::<PyArray1<TonicEvent>>() {
        let a = a.readonly();
        match a.as_slice() {
            Ok(s) => s.iter().map(|e| e.event()).collect(),
            Err(_) => a.as_array().iter().map(|e| e.event()).collect(),
        }
    } else {
        from_fields(obj, what)?
    };
    if let Some(k) = events.windows(2).position(|w| w[1].t_us < w[0].t_us) {
        return Err(BrailleError::new_err(format!(
            "{what}[{}]: t = {} us comes before the previous event's {} us (events must be in time order)",
            k + 1,
            events[k + 1].t_us,
            events[k].t_us
        )));
    }
    Ok(events)
}

/// Any structured array with integer fields `x, y, t, p`, read field by field (one copy each).
fn from_fields(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Event>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let names = obj
        .getattr("dtype")
        .and_then(|d| d.getattr("names"))
        .ok()
        .filter(|n| !n.is_none())
        .map(|n| n.extract::<Vec<String>>())
        .transpose()?;
    let Some(names) = names else {
        return Err(PyTypeError::new_err(format!(
            "{what}: expected a NumPy structured array with fields x, y, t, p (Tonic's layout; neurobraille.EVENTS_DTYPE), got {}",
            obj.get_type().name()?
        )));
    };
    if obj.getattr("ndim")?.extract::<usize>()? != 1 {
        return Err(PyValueError::new_err(format!("{what}: expected a one-dimensional array of events")));
    }
    let mut fields: Vec<Vec<i64>> = Vec::with_capacity(4);
    for f in ["x", "y", "t", "p"] {
        if !names.iter().any(|n| n == f) {
            return Err(PyValueError::new_err(format!(
                "{what}: no field {f:?} in the dtype (fields {names:?}; x, y, t, p are needed)"
            )));
        }
        let column = obj.get_item(f)?;
        let kind: String = column.getattr("dtype")?.getattr("kind")?.extract()?;
        if !matches!(kind.as_str(), "i" | "u" | "b") {
            return Err(PyValueError::new_err(format!(
                "{what}: field {f:?} has dtype {}; integer fields are needed (t in microseconds)",
                column.getattr("dtype")?.str()?
            )));
        }
        let column = np.getattr("ascontiguousarray")?.call1((column, "int64"))?;
        fields.push(column.cast::<PyArray1<i64>>()?.readonly().as_slice()?.to_vec());
    }
    let (xs, ys, ts, ps) = (&fields[0], &fields[1], &fields[2], &fields[3]);
    let mut events = Vec::with_capacity(ts.len());
    for k in 0..ts.len() {
        let (x, y) = (xs[k], ys[k]);
        if !(0..=65535).contains(&x) || !(0..=65535).contains(&y) {
            return Err(BrailleError::new_err(format!(
                "{what}[{k}]: pixel (x {x}, y {y}) outside 0..65535 (t = {} us)",
                ts[k]
            )));
        }
        events.push(Event::new(ts[k], x as u16, y as u16, Polarity::from_on(ps[k] > 0)));
    }
    Ok(events)
}

fn open(path: &Path, resolution: Option<Resolution>, stream_id: Option<u32>) -> PyResult<Box<dyn EventSource>> {
    formats::open(path, &OpenOptions { resolution, stream_id }).or_py()
}

fn info_of<'py>(py: Python<'py>, info: &formats::StreamInfo) -> PyResult<Bound<'py, PyAny>> {
    to_python(py, info)
}

/// Reads a whole event file (AEDAT 4.0, CSV or NumPy, told by its first bytes, then its extension)
/// into one array of `EVENTS_DTYPE`. Coordinates are checked against `resolution` (width, height)
/// when given, else against what the file declares. Use `iter_events` for files larger than memory.
#[pyfunction]
#[pyo3(signature = (path, resolution=None, stream_id=None))]
pub fn read_events<'py>(
    py: Python<'py>,
    path: PathBuf,
    resolution: Option<Vec<i64>>,
    stream_id: Option<u32>,
) -> PyResult<Bound<'py, PyArray1<TonicEvent>>> {
    let resolution = resolution_of("resolution", resolution)?;
    let events = py.detach(|| -> PyResult<Vec<TonicEvent>> {
        let mut src = open(&path, resolution, stream_id)?;
        let mut out = Vec::new();
        while let Some(chunk) = src.next_chunk().or_py()? {
            out.extend(chunk.iter().map(TonicEvent::from));
        }
        Ok(out)
    })?;
    Ok(to_array(py, events))
}

/// What an event file declares: its format, its sensor's resolution (if any) and its source.
#[pyfunction]
#[pyo3(signature = (path, stream_id=None))]
pub fn event_file_info(py: Python<'_>, path: PathBuf, stream_id: Option<u32>) -> PyResult<Bound<'_, PyAny>> {
    let src = open(&path, None, stream_id)?;
    info_of(py, src.info())
}

/// Writes events in the format of the path's extension (`.aedat4`, `.csv`, `.npy`); the file
/// appears only once complete, and an existing file is replaced only with `overwrite`. Returns
/// the number of events written.
#[pyfunction]
#[pyo3(signature = (path, events, resolution=None, overwrite=false))]
pub fn write_events(
    py: Python<'_>,
    path: PathBuf,
    events: &Bound<'_, PyAny>,
    resolution: Option<Vec<i64>>,
    overwrite: bool,
) -> PyResult<usize> {
    let resolution = resolution_of("resolution", resolution)?;
    let events = events_of(events, "events")?;
    if let Some(r) = resolution
        && let Some((k, e)) = events.iter().enumerate().find(|(_, e)| !r.contains(e.x, e.y))
    {
        return Err(BrailleError::new_err(format!("events[{k}]: pixel (x {}, y {}) outside the {r} sensor", e.x, e.y)));
    }
    py.detach(|| -> PyResult<usize> {
        let mut sink = formats::create(&path, resolution, overwrite).or_py()?;
        sink.write(&events).or_py()?;
        sink.finish().or_py()?;
        Ok(events.len())
    })
}

/// Streams an event file in arrays of at most `chunk_events` events, with bounded memory.
#[pyfunction]
#[pyo3(signature = (path, chunk_events=65536, resolution=None, stream_id=None))]
pub fn iter_events(
    path: PathBuf,
    chunk_events: usize,
    resolution: Option<Vec<i64>>,
    stream_id: Option<u32>,
) -> PyResult<EventFileReader> {
    if chunk_events == 0 {
        return Err(PyValueError::new_err("chunk_events must be at least 1"));
    }
    let resolution = resolution_of("resolution", resolution)?;
    let src = open(&path, resolution, stream_id)?;
    Ok(EventFileReader { src, chunk_events, pending: Vec::new(), start: 0, done: false })
}

/// An event file read chunk by chunk: iterate to get arrays of `EVENTS_DTYPE`.
#[pyclass(unsendable, module = "neurobraille")]
pub struct EventFileReader {
    src: Box<dyn EventSource>,
    chunk_events: usize,
    /// Decoded events, of which those from `start` on are not yet handed out.
    pending: Vec<TonicEvent>,
    start: usize,
    done: bool,
}

#[pymethods]
impl EventFileReader {
    /// What the file declares: format, resolution, source.
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        info_of(py, self.src.info())
    }

    #[getter]
    fn path(&self) -> PathBuf {
        self.src.path().to_path_buf()
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<TonicEvent>>>> {
        if self.start == self.pending.len() {
            self.pending.clear();
            self.start = 0;
        }
        while !self.done && self.pending.len() - self.start < self.chunk_events {
            match self.src.next_chunk().or_py()? {
                Some(chunk) => self.pending.extend(chunk.iter().map(TonicEvent::from)),
                None => self.done = true,
            }
        }
        if self.start == self.pending.len() {
            return Ok(None);
        }
        let end = (self.start + self.chunk_events).min(self.pending.len());
        let out = if self.start == 0 && end == self.pending.len() {
            std::mem::take(&mut self.pending)
        } else {
            self.pending[self.start..end].to_vec()
        };
        self.start = if self.pending.is_empty() { 0 } else { end };
        Ok(Some(to_array(py, out)))
    }

    fn __repr__(&self) -> String {
        format!("EventFileReader({:?}, chunk_events={})", self.src.path().display().to_string(), self.chunk_events)
    }
}
