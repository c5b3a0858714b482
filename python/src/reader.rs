//! The word reader from Python: a whole array of events at once, or a stream fed chunk by chunk.

use crate::errors::{OrPy, choice, name_of, to_python};
use crate::events::{events_of, resolution_of};
use encoders::Resolution;
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::code::BrailleCode;
use pipeline::reader::{ReadOutput, ReadWord, Spell, Speller, StreamReader, Timing, TimingMode};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use snn::model_file::Arch;
use std::path::PathBuf;
use std::sync::Arc;

/// The shipped models, found at `BRAILLE_MODELS` or else in the repository the package was
/// built from: those trained at the `nominal` preset, as `braille read`'s.
fn shipped_models(given: Option<PathBuf>) -> PathBuf {
    given
        .or_else(|| std::env::var_os("BRAILLE_MODELS").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/nominal")))
}

/// What a stream borrows: the loaded models and the speller, shared.
struct Shared {
    models: Arc<ReaderModels>,
    speller: Arc<Speller>,
}

type Stream<'a> = StreamReader<'a>;

self_cell::self_cell!(
    struct StreamCell {
        owner: Shared,
        #[covariant]
        dependent: Stream,
    }
);

/// One word read.
#[pyclass(frozen, get_all, module = "neurobraille")]
pub struct Word {
    /// As the speller corrected it.
    text: String,
    /// The letters as registered.
    raw: String,
    /// The first letter's first detection and the last letter's last, in stream microseconds.
    t_start_us: i64,
    t_end_us: i64,
    /// Each letter's mean confidence over its segment.
    confidences: Vec<f32>,
    /// The reader could not read it (its letters fit no word): a marked stretch, not a word.
    unreadable: bool,
    details: ReadWordJson,
}

struct ReadWordJson(String);

impl<'py> IntoPyObject<'py> for &ReadWordJson {
    type Target = PyAny;
    type Output = Bound<'py, PyAny>;
    type Error = PyErr;
    fn into_pyobject(self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?.getattr("loads")?.call1((self.0.as_str(),))
    }
}

impl Word {
    fn of(w: &ReadWord) -> PyResult<Word> {
        Ok(Word {
            text: w.text.clone(),
            raw: w.raw.clone(),
            t_start_us: w.chars.first().map_or(0, |c| c.t_start_us),
            t_end_us: w.chars.last().map_or(0, |c| c.t_end_us),
            confidences: w.chars.iter().map(|c| c.confidence).collect(),
            unreadable: w.unreadable,
            details: ReadWordJson(serde_json::to_string(w).map_err(|e| PyValueError::new_err(e.to_string()))?),
        })
    }
}

#[pymethods]
impl Word {
    fn __repr__(&self) -> String {
        format!("Word({:?}, raw={:?}, t_start_us={}, t_end_us={})", self.text, self.raw, self.t_start_us, self.t_end_us)
    }

    fn __str__(&self) -> String {
        self.text.clone()
    }
}

fn words_of(out: &mut Vec<ReadOutput>) -> PyResult<Vec<Word>> {
    out.drain(..)
        .filter_map(|o| match o {
            ReadOutput::Word(w) => Some(Word::of(&w)),
            ReadOutput::Char(_) => None,
        })
        .collect()
}

/// The paper's reader: the segmentation network finds characters in 10 ms frames of events, a
/// character classifier (the SNN or the ResNet) reads them, the temporal filter makes words and
/// the speller corrects them. Loaded once; each `read` or `stream` has its own state.
#[pyclass(frozen, module = "neurobraille")]
pub struct Reader {
    models: Arc<ReaderModels>,
    speller: Arc<Speller>,
    timing: Timing,
    arch: Arch,
    spell: Spell,
    braille: BrailleCode,
}

#[pymethods]
impl Reader {
    /// `arch`: "snn" or "resnet" (the shipped models of that architecture, unless `segmenter` and
    /// `classifier` name model files). `spell`: "lexicon", "textblob" or "none". `timing`:
    /// "estimated" (the speed from the events alone; `speed_mm_s` a hint), "paper" (the paper's
    /// fixed 10 ms bins, 70 ms and 1 s) or "given" (reads at `speed_mm_s`). `runner`: how the SNN
    /// reads a frame's window, "sliding" or "engine" (the same output). `models_dir`: where the
    /// shipped models are [default: $BRAILLE_MODELS, else the repository's models/nominal/].
    /// `braille`: the code of the print, "grade1-letters" (the paper's letters) or "ueb-g1" /
    /// "ueb-g2" (the cell readers in `models_dir`'s ueb/ folder, words back-translated to print).
    /// `chip`: "loihi2" (or another chip that holds both SNNs) runs the segmentation network and
    /// the classifier in that chip's arithmetic, every window from rest (docs/chips.md), quantised
    /// by `quantisation`; the same as `braille eval words --chip`.
    #[new]
    #[pyo3(signature = (arch="snn", spell="lexicon", timing="estimated", speed_mm_s=None, segmenter=None, classifier=None, runner="sliding", models_dir=None, braille="grade1-letters", chip=None, quantisation="global"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        arch: &str,
        spell: &str,
        timing: &str,
        speed_mm_s: Option<f64>,
        segmenter: Option<PathBuf>,
        classifier: Option<PathBuf>,
        runner: &str,
        models_dir: Option<PathBuf>,
        braille: &str,
        chip: Option<&str>,
        quantisation: &str,
    ) -> PyResult<Reader> {
        let chip: Option<snn::chip::Chip> = chip.map(|c| choice("chip", c)).transpose()?;
        let quantisation: snn::chip::xylo::Quantisation = choice("quantisation", quantisation)?;
        let arch: Arch = choice("arch", arch)?;
        let braille: BrailleCode = choice("braille", braille)?;
        let spell: Spell = choice("spell", spell)?;
        let mode: TimingMode = choice("timing", timing)?;
        let runner: SnnRunner = choice("runner", runner)?;
        let timing = Timing::from_mode(mode, speed_mm_s).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let pipeline::shipped::ReaderFiles { segmenter: ds, classifier: dc } =
            pipeline::shipped::reader_for(&shipped_models(models_dir), arch, braille);
        let segmenter = segmenter.unwrap_or(ds);
        let classifier = classifier.unwrap_or(dc);
        let (models, speller) = py
            .detach(|| {
                let mut models = ReaderModels::load(&segmenter, &classifier, runner)?;
                if let Some(c) = chip {
                    let on_chip = |m: pipeline::classify::WindowModel, path: &PathBuf| {
                        m.on_chip(c, quantisation).map_err(|e| pipeline::Error::Model {
                            path: path.clone(),
                            what: format!("in {c}'s arithmetic: {e}"),
                        })
                    };
                    models = ReaderModels {
                        segmenter: on_chip(models.segmenter, &segmenter)?,
                        classifier: on_chip(models.classifier, &classifier)?,
                        ..models
                    };
                }
                Ok::<_, pipeline::Error>((models, Speller::in_code(spell, braille)?))
            })
            .or_py()?;
        Ok(Reader { models: Arc::new(models), speller: Arc::new(speller), timing, arch, spell, braille })
    }

    /// Reads a whole array of events (fields x, y, t, p) from a sensor of `resolution`
    /// (width, height) and returns the words.
    #[pyo3(signature = (events, resolution=None))]
    fn read(&self, py: Python<'_>, events: &Bound<'_, PyAny>, resolution: Option<Vec<i64>>) -> PyResult<Vec<Word>> {
        let resolution = resolution_of("resolution", resolution)?.unwrap_or(Resolution::DVXPLORER);
        let events = events_of(events, "events")?;
        let all = py.detach(|| self.models.read(&events, resolution, self.timing, &self.speller)).or_py()?;
        all.words.iter().map(Word::of).collect()
    }

    /// A stream to feed chunk by chunk (`push`), its words returned as they complete; `finish`
    /// ends it. Memory stays bounded whatever the stream's length.
    #[pyo3(signature = (resolution=None))]
    fn stream(&self, resolution: Option<Vec<i64>>) -> PyResult<WordStream> {
        let resolution = resolution_of("resolution", resolution)?.unwrap_or(Resolution::DVXPLORER);
        let shared = Shared { models: self.models.clone(), speller: self.speller.clone() };
        let timing = self.timing;
        let cell = StreamCell::try_new(shared, |s| s.models.stream(timing, resolution, &s.speller)).or_py()?;
        Ok(WordStream { cell: Some(cell), out: Vec::new(), next_index: 0 })
    }

    #[getter]
    fn arch(&self) -> String {
        name_of(&self.arch)
    }

    #[getter]
    fn spell(&self) -> String {
        name_of(&self.spell)
    }

    #[getter]
    fn braille(&self) -> String {
        name_of(&self.braille)
    }

    #[getter]
    fn timing<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.timing)
    }

    fn __repr__(&self) -> String {
        format!("Reader(arch={:?}, spell={:?}, timing={:?})", name_of(&self.arch), name_of(&self.spell), self.timing)
    }
}

/// A stream being read: `push` chunks of events in time order, get the words completed so far.
#[pyclass(module = "neurobraille")]
pub struct WordStream {
    cell: Option<StreamCell>,
    out: Vec<ReadOutput>,
    /// Events pushed so far, to name an event in errors.
    next_index: u64,
}

impl WordStream {
    fn cell(&mut self) -> PyResult<&mut StreamCell> {
        self.cell.as_mut().ok_or_else(|| {
            crate::errors::BrailleError::new_err("the stream is finished; start another with Reader.stream()")
        })
    }
}

#[pymethods]
impl WordStream {
    /// Feeds the next events (in time order, after those pushed before) and returns the words
    /// they complete.
    fn push(&mut self, py: Python<'_>, events: &Bound<'_, PyAny>) -> PyResult<Vec<Word>> {
        let what = format!("chunk from event {}", self.next_index);
        let events = events_of(events, &what)?;
        self.next_index += events.len() as u64;
        let mut out = std::mem::take(&mut self.out);
        let cell = self.cell()?;
        py.detach(|| cell.with_dependent_mut(|_, r| r.push_all(&events, &mut out)))
            .map_err(|e| crate::errors::BrailleError::new_err(format!("{what}: {e}")))?;
        let words = words_of(&mut out);
        self.out = out;
        words
    }

    /// Ends the stream: the words still open are completed and returned.
    fn finish(&mut self, py: Python<'_>) -> PyResult<Vec<Word>> {
        let mut out = std::mem::take(&mut self.out);
        let cell = self.cell()?;
        py.detach(|| cell.with_dependent_mut(|_, r| r.finish(&mut out))).or_py()?;
        self.cell = None;
        words_of(&mut out)
    }

    /// The reader's counters so far (frames, segments, words, speed estimates, ...).
    #[getter]
    fn stats<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let cell = self.cell()?;
        to_python(py, &cell.borrow_dependent().stats)
    }

    /// The speed the reader is reading at, in mm/s (its estimate with estimated timing).
    #[getter]
    fn speed_mm_s(&mut self) -> PyResult<Option<f64>> {
        Ok(self.cell()?.borrow_dependent().speed_mm_s())
    }
}
