//! A lab's recordings folder from Python (docs/recordings.md): the manifest checked as `braille
//! recordings check` checks it, each scan's line, and its events as a NumPy array on demand.

use crate::errors::{OrPy, choice, to_python};
use crate::events::{TonicEvent, to_array, tonic_events};
use corpus::recordings::{Recording as Line, Recordings as Folder, Role};
use numpy::PyArray1;
use pyo3::prelude::*;
use std::path::PathBuf;

/// One scan of a recordings folder: its manifest line. The label fields (`text`, `speed_mm_s`,
/// `depth_mm`) are for training and scoring; a reader gets the events only.
#[pyclass(frozen, get_all, module = "neurobraille")]
pub struct Recording {
    /// The event file, as the manifest names it (relative to the folder), and its full path.
    file: PathBuf,
    path: PathBuf,
    /// `"train"`, `"val"` or `"test"`.
    role: String,
    /// The printed row, as written on the board.
    text: String,
    speed_mm_s: f64,
    depth_mm: f64,
    /// The manifest's further columns, by name.
    extra: std::collections::BTreeMap<String, String>,
    /// The manifest's line (1-based; the header is line 1).
    line: u64,
}

#[pymethods]
impl Recording {
    /// The scan's events, `EVENTS_DTYPE`, read whole (a bad file is refused naming the file and
    /// the place).
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<TonicEvent>>> {
        let path = self.path.clone();
        let events = py
            .detach(|| {
                encoders::formats::read_all(&path, &encoders::OpenOptions::default()).map(|(_, e)| tonic_events(&e))
            })
            .or_py()?;
        Ok(to_array(py, events))
    }

    fn __repr__(&self) -> String {
        format!(
            "Recording(file={:?}, role={:?}, text={:?}, speed_mm_s={}, depth_mm={})",
            self.file, self.role, self.text, self.speed_mm_s, self.depth_mm
        )
    }
}

impl Recording {
    fn of(folder: &Folder, r: &Line) -> Recording {
        Recording {
            path: folder.path(r),
            file: r.file.clone(),
            role: r.role.name().to_string(),
            text: r.text.clone(),
            speed_mm_s: r.speed_mm_s,
            depth_mm: r.depth_mm,
            extra: r.extra.clone(),
            line: r.line,
        }
    }
}

/// A recordings folder: `DIR/manifest.csv` and its event files. Opening reads and checks the
/// manifest (a bad line is refused naming the line and the field); `check()` also reads every
/// event file through and summarises the folder per role and condition, as `braille recordings
/// check --json` does.
#[pyclass(frozen, module = "neurobraille")]
pub struct Recordings {
    folder: Folder,
}

#[pymethods]
impl Recordings {
    #[new]
    fn new(dir: PathBuf) -> PyResult<Recordings> {
        Ok(Recordings { folder: Folder::open(&dir).or_py()? })
    }

    /// The folder.
    #[getter]
    fn dir(&self) -> PathBuf {
        self.folder.dir.clone()
    }

    /// The scans of `role` ("train", "val" or "test"), or all of them, in the manifest's order.
    #[pyo3(signature = (role=None))]
    fn scans(&self, role: Option<&str>) -> PyResult<Vec<Recording>> {
        let role: Option<Role> = role.map(|r| choice("role", r)).transpose()?;
        Ok(self
            .folder
            .recordings
            .iter()
            .filter(|r| role.is_none_or(|x| r.role == x))
            .map(|r| Recording::of(&self.folder, r))
            .collect())
    }

    /// Reads every event file through and summarises the folder (a dict as `braille recordings
    /// check --json` prints it).
    fn check<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let summary = py.detach(|| self.folder.check()).or_py()?;
        to_python(py, &summary)
    }

    fn __len__(&self) -> usize {
        self.folder.recordings.len()
    }

    fn __repr__(&self) -> String {
        let n = |role: Role| self.folder.role(role).count();
        format!(
            "Recordings({:?}: {} train, {} val, {} test scans)",
            self.folder.dir,
            n(Role::Train),
            n(Role::Val),
            n(Role::Test)
        )
    }
}
