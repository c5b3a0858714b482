//! The networks that read the reader's windows: the ResNet (batch of one, on our inference path,
//! `learn::resnet::folded`; each bin of a stream cropped once) and the SNN (stepped, one step per
//! frame, either sharing its first layer's work between overlapping windows or on the
//! event-driven engine), with their work counted. Both architectures get identical windows of
//! identical streams.

use crate::error::{Error, Result};
use crate::input::CharInput;
use crate::models::Model;
use crate::reader::{Window, WindowClassifier};
use learn::resnet::folded::FoldedResnet;
use serde::{Deserialize, Serialize};
use snn::chip::xylo::{Quantisation, Run};
use snn::chip::{Chip, ChipModel};
use snn::engine::{Engine, EngineState, Mode};
use snn::model_file::{Readout, SnnModel};
use snn::sliding::{RunScratch, Sliding};
use std::path::Path;
use std::time::Instant;

pub use snn::scoring::argmax;

/// How the SNN reads a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SnnRunner {
    /// The first layer's synaptic currents are computed once per frame and shared by the
    /// overlapping windows (`snn::sliding`); exactly the trained network's output.
    Sliding,
    /// Every window runs on the event-driven engine (stepped mode) from rest.
    Engine,
}

/// A cell of a cropped bin: polarity, row, column (of the crop) and its events.
type CroppedCell = (usize, usize, usize, f32);

/// Per bin of the stream: its events cropped and pooled to the model's grid, `(polarity, row,
/// col, count)`, and the layer-0 currents already made from them (per vertical shift).
struct BinCache {
    t_end_us: i64,
    cells: Vec<CroppedCell>,
    /// Events and their sum of rows (for the vertical centring).
    mass: f64,
    moment: f64,
    currents: Vec<(i64, Vec<f32>)>,
}

/// A stream's bins cropped and pooled once each, for the runners that take a window's dense crop
/// (the ResNet, a chip): the crop of a frame's window is then its bins' cells written into their
/// planes, [`CharInput::crop_window`]'s numbers (each cell's counts summed in the same order),
/// without cropping every bin again at each of the frames whose window holds it.
#[derive(Default)]
struct CropCache {
    /// Consecutive bins by end time: each its crop's non-zero cells, as [`BinCropper::crop`] gives
    /// them.
    bins: std::collections::VecDeque<(i64, Vec<CroppedCell>)>,
    cropper: BinCropper,
}

impl CropCache {
    /// The window's crop, as [`CharInput::crop_window`] gives it.
    fn window(&mut self, input: &CharInput, w: &Window) -> Result<Vec<f32>> {
        input.check_window(w)?;
        let [planes, h, wd] = input.source_shape();
        let ends: Vec<i64> = w.bin_ends_us().collect();
        let kept = keep_window_bins(&mut self.bins, &ends, |b| b.0);
        for (cells, &t) in w.bins().zip(&ends).skip(kept) {
            self.bins.push_back((t, self.cropper.crop(input, cells, w.height, w.width)));
        }
        let mut out = vec![0f32; planes * h * wd];
        for (plane, (_, cells)) in out.chunks_exact_mut(2 * h * wd).zip(&self.bins) {
            for &(pol, r, col, v) in cells {
                plane[(pol * h + r) * wd + col] = v;
            }
        }
        Ok(input.centre_band(out))
    }
}

/// Keeps the cached bins (consecutive, known by their end times) that are the window's oldest
/// ones, whose ends are `ends`, and returns how many: the window's later bins are to be cropped
/// and pushed. A cache that is not the window's start (a stream started again) is emptied.
fn keep_window_bins<T>(bins: &mut std::collections::VecDeque<T>, ends: &[i64], end_of: impl Fn(&T) -> i64) -> usize {
    if let Some(&first) = ends.first() {
        while bins.front().is_some_and(|b| end_of(b) < first) {
            bins.pop_front();
        }
    }
    if bins.len() > ends.len() || bins.iter().zip(ends).any(|(b, &t)| end_of(b) != t) {
        bins.clear();
    }
    bins.len()
}

/// What a loaded model runs: shared by every stream (nothing here changes while reading).
#[allow(clippy::large_enum_variant)] // one per model: the size does not matter
enum Runner {
    Resnet {
        model: FoldedResnet,
        input: CharInput,
    },
    Engine {
        model: SnnModel,
        input: CharInput,
        engine: Engine,
    },
    Sliding {
        model: SnnModel,
        input: CharInput,
        net: Sliding,
    },
    /// The SNN mapped into a chip's number formats, every window run as the chip computes from
    /// rest; `readout_scale` takes its readout back to the float network's units.
    Chip {
        model: SnnModel,
        input: CharInput,
        chip: ChipModel,
        quantisation: Quantisation,
        readout_scale: f32,
    },
}

/// A trained network that reads windows. It holds parameters only: it is shared (`&self`,
/// `Send + Sync`) by any number of streams, each with its own [`WindowState`].
pub struct WindowModel {
    runner: Runner,
    classes: Vec<String>,
    /// A segmentation network's operating point, from its model file (`None`: never calibrated).
    operating_point: Option<crate::reader::OperatingPoint>,
}

/// What one stream keeps of one model between windows: the engine's neuron state or the sliding
/// runner's per-bin cache, and the work counted.
pub struct WindowState {
    kind: StateKind,
    pub stats: CallStats,
}

#[allow(clippy::large_enum_variant)] // one per stream and model
enum StateKind {
    Crops(CropCache),
    Engine(EngineState),
    Sliding { bins: std::collections::VecDeque<BinCache>, cropper: BinCropper, run: RunScratch },
}

/// A model's work on one stream.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CallStats {
    /// Windows read, synaptic operations (SNN), time spent.
    pub calls: u64,
    pub synops: u64,
    pub nanos: u64,
    /// The time of each call (bounded memory).
    pub latency: Histogram,
}

impl CallStats {
    pub fn merge(&mut self, other: &CallStats) {
        self.calls += other.calls;
        self.synops += other.synops;
        self.nanos += other.nanos;
        self.latency.merge(&other.latency);
    }
}

/// Durations in nanoseconds, 1 ns to an hour, with three significant digits (hdrhistogram):
/// percentiles within 0.1% of the durations recorded, in constant memory however many calls.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    inner: hdrhistogram::Histogram<u64>,
}

/// The longest duration kept apart, in ns (an hour); longer ones are counted as an hour.
const HISTOGRAM_MAX_NS: u64 = 3_600_000_000_000;

impl Default for Histogram {
    fn default() -> Self {
        let inner = hdrhistogram::Histogram::new_with_bounds(1, HISTOGRAM_MAX_NS, 3).expect("valid bounds");
        Histogram { inner }
    }
}

impl Histogram {
    pub fn add(&mut self, ns: u64) {
        self.inner.saturating_record(ns.clamp(1, HISTOGRAM_MAX_NS));
    }

    pub fn total(&self) -> u64 {
        self.inner.len()
    }

    /// The `q`-quantile (0-1) in ns, three significant digits; `None` when empty.
    pub fn quantile_ns(&self, q: f64) -> Option<f64> {
        (!self.inner.is_empty()).then(|| self.inner.value_at_quantile(q.clamp(0.0, 1.0)) as f64)
    }

    /// The durations in buckets `per_octave` to an octave: each non-empty bucket's lower edge
    /// (ns, `2^(k / per_octave)`) and its count, for a histogram's picture.
    pub fn octave_buckets(&self, per_octave: u32) -> Vec<(f64, u64)> {
        let mut out: std::collections::BTreeMap<i64, u64> = std::collections::BTreeMap::new();
        for v in self.inner.iter_recorded() {
            let k = ((v.value_iterated_to().max(1) as f64).log2() * per_octave as f64).floor() as i64;
            *out.entry(k).or_default() += v.count_at_value();
        }
        out.into_iter().map(|(k, c)| (2f64.powf(k as f64 / per_octave as f64), c)).collect()
    }

    pub fn merge(&mut self, other: &Histogram) {
        // both have the same bounds, so adding cannot fail
        self.inner.add(&other.inner).expect("histograms of the same bounds");
    }
}

/// Written as the percentiles a reader wants and the recorded values with their counts.
impl Serialize for Histogram {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let recorded: Vec<(u64, u64)> =
            self.inner.iter_recorded().map(|v| (v.value_iterated_to(), v.count_at_value())).collect();
        let mut st = s.serialize_struct("Histogram", 5)?;
        st.serialize_field("count", &self.total())?;
        st.serialize_field("p50_ns", &self.quantile_ns(0.5))?;
        st.serialize_field("p99_ns", &self.quantile_ns(0.99))?;
        st.serialize_field("max_ns", &(!self.inner.is_empty()).then(|| self.inner.max()))?;
        st.serialize_field("recorded_ns_count", &recorded)?;
        st.end()
    }
}

impl WindowModel {
    /// A ResNet, folded for inference ([`learn::resnet::folded`]), whose input is made as `input`
    /// says.
    pub fn resnet(model: FoldedResnet, input: CharInput, classes: Vec<String>) -> WindowModel {
        WindowModel { runner: Runner::Resnet { model, input }, classes, operating_point: None }
    }

    /// An SNN whose input spikes are made as `input` says.
    pub fn snn(model: SnnModel, input: CharInput, runner: SnnRunner) -> Result<WindowModel> {
        let n = 2 * input.shape()[1] * input.shape()[2];
        if model.network.n_inputs() != n {
            return Err(Error::Mismatch { what: "the preparation's inputs differ from the network's" });
        }
        let classes = model.classes.clone();
        let runner = match runner {
            SnnRunner::Engine => {
                let engine = Engine::new(&model.network, model.config.dt_us, Mode::Stepped)?;
                Runner::Engine { model, input, engine }
            }
            SnnRunner::Sliding => Runner::Sliding { net: Sliding::new(&model.network)?, model, input },
        };
        Ok(WindowModel { runner, classes, operating_point: None })
    }

    /// A loaded model that reads character windows (`path` names it in errors).
    pub fn from_model(model: Model, path: &Path, runner: SnnRunner) -> Result<WindowModel> {
        let input = model.char_input(path)?;
        let bad = |what: String| Error::Model { path: path.to_path_buf(), what };
        input.check_band().map_err(|e| bad(e.to_string()))?;
        let operating_point = match model.operating_point() {
            Some(v) => {
                let p: crate::reader::OperatingPoint =
                    serde_json::from_value(v.clone()).map_err(|e| bad(format!("header `operating_point`: {e}")))?;
                p.validate().map_err(|e| bad(format!("header `operating_point`: {e}")))?;
                Some(p)
            }
            None => None,
        };
        let m = match model {
            Model::Resnet(m) => {
                let folded = FoldedResnet::from_tensors(&m.config, &m.tensors).map_err(|e| bad(e.to_string()))?;
                WindowModel::resnet(folded, m.input, m.classes)
            }
            Model::Snn(m) => WindowModel::snn(m, input, runner).map_err(|e| bad(e.to_string()))?,
        };
        Ok(m.with_operating_point(operating_point))
    }

    /// The same model read at `point` (`None`: the paper's point).
    pub fn with_operating_point(mut self, point: Option<crate::reader::OperatingPoint>) -> WindowModel {
        self.set_operating_point(point);
        self
    }

    /// Reads the model at `point` from now on (`None`: the paper's point).
    pub fn set_operating_point(&mut self, point: Option<crate::reader::OperatingPoint>) {
        self.operating_point = point;
    }

    /// The operating point its model file records for a reader (a calibrated segmentation
    /// network), if any.
    pub fn operating_point(&self) -> Option<&crate::reader::OperatingPoint> {
        self.operating_point.as_ref()
    }

    /// A model file of either architecture trained on character windows.
    pub fn load(path: &Path, runner: SnnRunner) -> Result<WindowModel> {
        WindowModel::from_model(crate::models::load(path)?, path, runner)
    }

    pub fn classes(&self) -> &[String] {
        &self.classes
    }

    pub fn input(&self) -> &CharInput {
        match &self.runner {
            Runner::Resnet { input, .. }
            | Runner::Engine { input, .. }
            | Runner::Sliding { input, .. }
            | Runner::Chip { input, .. } => input,
        }
    }

    /// The architecture behind it.
    pub fn arch(&self) -> snn::model_file::Arch {
        match self.runner {
            Runner::Resnet { .. } => snn::model_file::Arch::Resnet,
            Runner::Engine { .. } | Runner::Sliding { .. } | Runner::Chip { .. } => snn::model_file::Arch::Snn,
        }
    }

    /// The chip whose arithmetic runs it, and how it was quantised (`None`: the float engine).
    pub fn chip(&self) -> Option<(Chip, Quantisation)> {
        match &self.runner {
            Runner::Chip { chip, quantisation, .. } => Some((chip.chip(), *quantisation)),
            _ => None,
        }
    }

    /// The same SNN run in `chip`'s arithmetic (docs/chips.md), quantised by `quantisation`,
    /// every window from rest with the chip's latency steps; a ResNet, or a network the chip cannot
    /// hold, is an error naming the rule.
    pub fn on_chip(self, chip: Chip, quantisation: Quantisation) -> Result<WindowModel> {
        let (model, input) = match self.runner {
            Runner::Engine { model, input, .. }
            | Runner::Sliding { model, input, .. }
            | Runner::Chip { model, input, .. } => (model, input),
            Runner::Resnet { .. } => return Err(Error::Mismatch { what: "a ResNet runs on no chip" }),
        };
        let mapped = ChipModel::map(&model.network, chip, quantisation, model.config.readout)?;
        let readout_scale = mapped.model.readout_scale();
        Ok(WindowModel {
            runner: Runner::Chip { chip: mapped.model, model, input, quantisation, readout_scale },
            classes: self.classes,
            operating_point: self.operating_point,
        })
    }
}

fn softmax(v: &[f32]) -> Vec<f32> {
    let m = v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let e: Vec<f32> = v.iter().map(|x| (x - m).exp()).collect();
    let s: f32 = e.iter().sum();
    e.into_iter().map(|x| x / s).collect()
}

/// Crops a stream's bins ([`BinCropper::crop`]), with the stream's tables: where each of the
/// reader's cells falls in the crop ([`CharInput::crop_cell`] for every cell, made at the first
/// bin: a stream's grid does not change), the crop's cells as `(polarity, row, column)`, and a
/// zeroed grid of the crop to sum in.
#[derive(Default)]
struct BinCropper {
    /// The reader's grid (height, width) the tables are for (`None` before the first bin).
    grid: Option<(usize, usize)>,
    /// The crop's cell of each of the reader's cells, or `u32::MAX` outside the crop.
    cell_of: Vec<u32>,
    /// `(polarity, row, column)` of each of the crop's cells.
    place_of: Vec<(u16, u16, u16)>,
    scratch: Vec<f32>,
    /// The crop's cells a bin touched, a bit each (read in order: no sort).
    touched: Vec<u64>,
}

impl BinCropper {
    /// A bin's cells cropped and pooled as [`CharInput::crop_window`] does, in ascending
    /// (polarity, row, column) order.
    fn crop(
        &mut self,
        input: &CharInput,
        cells: &[crate::reader::Cell],
        height: usize,
        width: usize,
    ) -> Vec<CroppedCell> {
        let [_, h, w] = input.source_shape();
        if self.grid != Some((height, width)) {
            self.grid = Some((height, width));
            self.cell_of = (0..2 * height * width)
                .map(|i| input.crop_cell(i as u32, height, width).map_or(u32::MAX, |j| j as u32))
                .collect();
            self.place_of =
                (0..2 * h * w).map(|j| ((j / (h * w)) as u16, (j / w % h) as u16, (j % w) as u16)).collect();
            self.scratch = vec![0.0; 2 * h * w];
            self.touched = vec![0; (2 * h * w).div_ceil(64)];
        }
        for c in cells {
            // a cell past the grid (none from the reader) is outside the crop, as `crop_cell` says
            let j = self.cell_of.get(c.input as usize).copied().unwrap_or(u32::MAX);
            if j == u32::MAX {
                continue;
            }
            self.scratch[j as usize] += c.count;
            self.touched[j as usize / 64] |= 1 << (j % 64);
        }
        let mut out = Vec::new();
        for (k, word) in self.touched.iter_mut().enumerate() {
            let mut bits = std::mem::take(word);
            while bits != 0 {
                let j = k * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let v = std::mem::take(&mut self.scratch[j]);
                let (pol, r, col) = self.place_of[j];
                out.push((pol as usize, r as usize, col as usize, v));
            }
        }
        out
    }
}

impl WindowModel {
    fn sliding(&self, st: &mut WindowState, w: &Window) -> Result<Vec<f32>> {
        let Runner::Sliding { model, input, net } = &self.runner else {
            unreachable!("called for the sliding runner only")
        };
        let StateKind::Sliding { bins, cropper, run } = &mut st.kind else {
            return Err(Error::Mismatch { what: "a window state of another model" });
        };
        let [_, h, wd] = input.shape();
        // the window's bins, cropped once each (the cache holds consecutive bins, known by their
        // end times: a reader following its speed estimate changes the bins' length)
        let ends: Vec<i64> = w.bin_ends_us().collect();
        let kept = keep_window_bins(bins, &ends, |b| b.t_end_us);
        for (cells, &t) in w.bins().zip(&ends).skip(kept) {
            let cells = cropper.crop(input, cells, w.height, w.width);
            let (mass, moment) =
                cells.iter().fold((0f64, 0f64), |(m, r), &(_, row, _, c)| (m + c as f64, r + c as f64 * row as f64));
            bins.push_back(BinCache { t_end_us: t, cells, mass, moment, currents: Vec::new() });
        }
        // the vertical centring of the whole window (of its band's rows, when the input has a
        // band), as `CharInput::spikes` (or `crop_window`'s band) does it
        let shift = if input.preprocess.normalises() {
            let (mass, moment) = bins.iter().fold((0f64, 0f64), |(m, r), b| (m + b.mass, r + b.moment));
            crate::preprocess::shift_of(mass, moment, h)
        } else {
            0
        };
        let mut active = Vec::new();
        for b in bins.iter_mut() {
            if b.currents.iter().all(|c| c.0 != shift) {
                active.clear();
                for &(pol, r, col, c) in &b.cells {
                    let r = r as i64 + shift;
                    if (0..h as i64).contains(&r) {
                        active.push((((pol * h + r as usize) * wd + col) as u32, c));
                    }
                }
                active.sort_unstable_by_key(|a| a.0);
                let mut cur = Vec::new();
                st.stats.synops += net.currents(&active, &mut cur)?;
                b.currents.push((shift, cur));
            }
        }
        let steps: Vec<&[f32]> = bins
            .iter()
            .map(|b| b.currents.iter().find(|c| c.0 == shift).map(|c| c.1.as_slice()).unwrap_or(&[]))
            .collect();
        let out = net.run_with(&steps, run);
        st.stats.synops += out.synops;
        Ok(match model.config.readout {
            Readout::MaxMembrane => softmax(&out.v_max),
            Readout::SpikeCount => softmax(&out.counts.iter().map(|&c| c as f32).collect::<Vec<_>>()),
        })
    }
}

impl WindowClassifier for WindowModel {
    type State = WindowState;

    fn new_state(&self) -> WindowState {
        let kind = match &self.runner {
            Runner::Resnet { .. } | Runner::Chip { .. } => StateKind::Crops(CropCache::default()),
            Runner::Engine { engine, .. } => StateKind::Engine(engine.state(0)),
            Runner::Sliding { .. } => StateKind::Sliding {
                bins: Default::default(),
                cropper: BinCropper::default(),
                run: RunScratch::default(),
            },
        };
        WindowState { kind, stats: CallStats::default() }
    }

    fn classify(&self, st: &mut WindowState, w: &Window) -> Result<Vec<f32>> {
        let t = Instant::now();
        let p = match (&self.runner, &mut st.kind) {
            (Runner::Resnet { model, input }, StateKind::Crops(crops)) => {
                let x = input.prepared(crops.window(input, w)?);
                softmax(&model.logits(&x)?)
            }
            (Runner::Engine { model, input, engine }, StateKind::Engine(state)) => {
                let image = input.crop_window(w)?;
                let train = input.spikes(&image, model.config.dt_us);
                engine.run_train(state, &train)?;
                st.stats.synops += state.stats.synops;
                match model.config.readout {
                    Readout::MaxMembrane => softmax(state.output_v_max()),
                    Readout::SpikeCount => {
                        let c: Vec<f32> =
                            state.output_counts(engine.n_outputs()).into_iter().map(|c| c as f32).collect();
                        softmax(&c)
                    }
                }
            }
            (Runner::Sliding { .. }, _) => self.sliding(st, w)?,
            (Runner::Chip { model, input, chip, readout_scale, .. }, StateKind::Crops(crops)) => {
                let image = crops.window(input, w)?;
                let train = input.spikes(&image, model.config.dt_us);
                let (readout, work) = chip.run_sample((0..train.n_steps()).map(|k| train.step(k)), Run::EventDriven)?;
                st.stats.synops += work.synops;
                softmax(&readout.iter().map(|r| r / readout_scale).collect::<Vec<_>>())
            }
            (Runner::Engine { .. } | Runner::Resnet { .. } | Runner::Chip { .. }, _) => {
                return Err(Error::Mismatch { what: "a window state of another model" });
            }
        };
        let ns = t.elapsed().as_nanos() as u64;
        st.stats.calls += 1;
        st.stats.nanos += ns;
        st.stats.latency.add(ns);
        Ok(p)
    }
}

/// The two networks of one reader: the segmentation network and the character classifier,
/// loaded once and checked to fit each other. Shared by every stream read with them.
pub struct ReaderModels {
    pub segmenter: WindowModel,
    pub classifier: WindowModel,
    /// The cell grid a cell reader places cells of one dot column with (`None`: the classifier's
    /// column stands; [`crate::grid`]). Loading sets the standard's.
    pub cell_grid: Option<crate::grid::CellGrid>,
    /// A background-activity filter the events pass before anything else. Loading takes the
    /// one the models were trained behind (their input's `denoise`; `None` for models trained on
    /// the events as they come).
    pub denoise: Option<encoders::denoise::NoiseFilterSettings>,
}

impl ReaderModels {
    /// Both networks in `chip`'s arithmetic ([`WindowModel::on_chip`]).
    pub fn on_chip(self, chip: Chip, quantisation: Quantisation) -> Result<ReaderModels> {
        Ok(ReaderModels {
            segmenter: self.segmenter.on_chip(chip, quantisation)?,
            classifier: self.classifier.on_chip(chip, quantisation)?,
            ..self
        })
    }

    /// Loads and checks the pair (either architecture, as each file's header says).
    pub fn load(segmenter: &Path, classifier: &Path, runner: SnnRunner) -> Result<ReaderModels> {
        let seg = WindowModel::load(segmenter, runner)?;
        let cls = WindowModel::load(classifier, runner)?;
        let bad = |path: &Path, what: String| Error::Model { path: path.to_path_buf(), what };
        if seg.classes() != ["background", "character"] {
            return Err(bad(segmenter, format!("not a segmentation network (classes {:?})", seg.classes())));
        }
        if !matches!(cls.classes().len(), 26 | 63) {
            return Err(bad(
                classifier,
                format!("not a character classifier of 26 letters or 63 cells (classes {:?})", cls.classes()),
            ));
        }
        if seg.input().labeler != cls.input().labeler {
            return Err(bad(classifier, format!("windows its input unlike {}", segmenter.display())));
        }
        if seg.input().denoise != cls.input().denoise {
            return Err(bad(
                classifier,
                format!(
                    "trained behind noise filter {:?}, {} behind {:?}",
                    cls.input().denoise,
                    segmenter.display(),
                    seg.input().denoise
                ),
            ));
        }
        let denoise = cls.input().denoise;
        Ok(ReaderModels { segmenter: seg, classifier: cls, cell_grid: Some(crate::grid::CellGrid::default()), denoise })
    }

    /// The reader's configuration with this timing, the models' windowing and the segmentation
    /// network's operating point (the paper's if its file records none).
    pub fn config(&self, timing: crate::reader::Timing) -> crate::reader::ReaderConfig {
        crate::reader::ReaderConfig {
            labeler: self.classifier.input().labeler.clone(),
            cell_grid: self.cell_grid.clone(),
            denoise: self.denoise,
            ..crate::reader::ReaderConfig::new(timing)
        }
        .with_operating_point(self.operating_point())
    }

    /// Where the reader reads the segmentation network.
    pub fn operating_point(&self) -> &crate::reader::OperatingPoint {
        self.segmenter.operating_point().unwrap_or(&crate::reader::OperatingPoint::PAPER)
    }

    /// Reads a whole stream of events in memory.
    pub fn read(
        &self,
        events: &[encoders::Event],
        resolution: encoders::Resolution,
        timing: crate::reader::Timing,
        speller: &crate::reader::Speller,
    ) -> Result<crate::reader::ReadAll<WindowState, WindowState>> {
        crate::reader::read_all(events, self.config(timing), resolution, &self.segmenter, &self.classifier, speller)
    }

    /// A streaming reader of one stream.
    pub fn stream<'m>(
        &'m self,
        timing: crate::reader::Timing,
        resolution: encoders::Resolution,
        speller: &'m crate::reader::Speller,
    ) -> Result<crate::reader::StreamReader<'m>> {
        crate::reader::StreamReader::new(self.config(timing), resolution, &self.segmenter, &self.classifier, speller)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loaded_models_are_shared_across_threads() {
        fn shared<T: Send + Sync>() {}
        shared::<WindowModel>();
        shared::<ReaderModels>();
        fn movable<T: Send>() {}
        movable::<WindowState>();
    }

    #[test]
    fn a_reader_whose_speed_changes_reads_the_same_with_both_snn_runners() {
        // the shipped SNN segmentation network on a stream whose speed jumps between 8 and 40 mm/s:
        // the reader retunes its bins within a window, and the sliding runner's cache of bins
        // (known by their end times) must give what running every window from rest gives
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/clean");
        let seg = models.join("snn-segment.safetensors");
        let mut ev = Vec::new();
        for (k, speed) in [8.0, 24.0, 12.0, 40.0, 16.0, 32.0].into_iter().enumerate() {
            let part = crate::speed::tests::moving(speed, true, 0.05, 0.7, k as u64);
            ev.extend(part.into_iter().map(|e| encoders::Event { t_us: e.t_us + k as i64 * 700_000, ..e }));
        }
        let speller = crate::reader::Speller::new(crate::reader::Spell::None);
        let run = |runner: SnnRunner, band: Option<std::ops::Range<usize>>| {
            let model = crate::models::load(&seg).unwrap();
            let mut input = model.char_input(&seg).unwrap();
            input.band = band;
            let crate::models::Model::Snn(snn) = model else { panic!("an SNN") };
            let m = WindowModel::snn(snn, input, runner).unwrap();
            let cfg = crate::reader::ReaderConfig {
                labeler: m.input().labeler.clone(),
                ..crate::reader::ReaderConfig::new(crate::reader::Timing::ESTIMATED)
            };
            let r = crate::reader::read_all(&ev, cfg, encoders::Resolution::DVXPLORER, &m, &m, &speller).unwrap();
            (r.words, r.stats)
        };
        // and again with the vertical centring in a band of rows wider than the crop's
        for band in [None, Some(4..116)] {
            let (sliding, stats) = run(SnnRunner::Sliding, band.clone());
            assert!(stats.speed_changes >= 5 && stats.segmenter_calls > 100, "{stats:?}");
            let s = stats.speed_mm_s.unwrap();
            assert!((s / 32.0 - 1.0).abs() < 0.06, "read at {s} mm/s at the end");
            let (engine, engine_stats) = run(SnnRunner::Engine, band.clone());
            assert_eq!(sliding, engine, "band {band:?}");
            assert_eq!(stats.segmenter_calls, engine_stats.segmenter_calls);
        }
    }

    /// A classifier that checks each window's cached crop against `crop_window`'s.
    struct SameCrops(CharInput);

    impl WindowClassifier for SameCrops {
        type State = (CropCache, usize);
        fn new_state(&self) -> Self::State {
            (CropCache::default(), 0)
        }
        fn classify(&self, st: &mut Self::State, w: &Window) -> Result<Vec<f32>> {
            let cached = st.0.window(&self.0, w)?;
            assert_eq!(cached, self.0.crop_window(w)?, "window {} at {} us", st.1, w.t_end_us);
            st.1 += 1;
            Ok(vec![0.1, 0.9])
        }
    }

    #[test]
    fn a_pair_reads_behind_its_models_filter_and_a_pair_trained_behind_two_is_refused() {
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models");
        let seg = models.join("nominal/snn-segment.safetensors");
        let plain =
            ReaderModels::load(&seg, &models.join("nominal/snn-words.safetensors"), SnnRunner::Sliding).unwrap();
        assert_eq!(plain.denoise, None);
        // the envelope's classifier was trained behind DV's filter; the shipped segmenter was not
        let filtered = models.join("envelope/snn-words.safetensors");
        let m = WindowModel::load(&filtered, SnnRunner::Sliding).unwrap();
        assert_eq!(m.input().denoise, Some(encoders::denoise::NoiseFilterSettings::DV_LAB));
        let e = ReaderModels::load(&seg, &filtered, SnnRunner::Sliding).err().expect("refused").to_string();
        assert!(e.contains("snn-words.safetensors") && e.contains("noise filter"), "{e}");
    }

    #[test]
    fn the_cached_crops_are_crop_windows_while_the_speed_changes() {
        // the ResNet segmentation network's input on a stream whose speed jumps between 8 and 40
        // mm/s (the reader retunes its bins within a window)
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/clean");
        let m = WindowModel::load(&models.join("resnet-tiny-segment.safetensors"), SnnRunner::Sliding).unwrap();
        let mut ev = Vec::new();
        for (k, speed) in [8.0, 24.0, 40.0, 16.0].into_iter().enumerate() {
            let part = crate::speed::tests::moving(speed, true, 0.05, 0.5, k as u64);
            ev.extend(part.into_iter().map(|e| encoders::Event { t_us: e.t_us + k as i64 * 500_000, ..e }));
        }
        // its input as it is, and centred in a band of rows wider than its crop
        let banded =
            CharInput { preprocess: crate::preprocess::Preprocess::Norm, band: Some(4..116), ..m.input().clone() };
        for input in [m.input().clone(), banded] {
            let check = SameCrops(input);
            let cfg = crate::reader::ReaderConfig {
                labeler: m.input().labeler.clone(),
                ..crate::reader::ReaderConfig::new(crate::reader::Timing::ESTIMATED)
            };
            let speller = crate::reader::Speller::new(crate::reader::Spell::None);
            let r = crate::reader::read_all(&ev, cfg, encoders::Resolution::DVXPLORER, &check, &m, &speller).unwrap();
            assert!(r.stats.speed_changes >= 3 && r.stats.segmenter_calls > 100, "{:?}", r.stats);
        }
    }

    #[test]
    fn a_bins_crop_is_its_non_zero_crop_cells_in_order_bin_after_bin() {
        // random bins through one cropper (its touched bits must not leak from bin to bin), each
        // against the crop cells `crop_cell` names, summed and in ascending order
        use rand::{Rng, SeedableRng};
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/clean");
        let m = WindowModel::load(&models.join("resnet-tiny-segment.safetensors"), SnnRunner::Sliding).unwrap();
        let input = m.input().clone();
        let (height, width) = (120, 160);
        let [_, h, w] = input.source_shape();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut cropper = BinCropper::default();
        for bin in 0..40 {
            let n = rng.random_range(0..400);
            let cells: Vec<crate::reader::Cell> = (0..n)
                .map(|_| crate::reader::Cell {
                    input: rng.random_range(0..2 * height * width + 10) as u32,
                    count: rng.random_range(1..5) as f32,
                })
                .collect();
            let mut want = std::collections::BTreeMap::new();
            for c in &cells {
                if let Some(j) = input.crop_cell(c.input, height, width) {
                    *want.entry(j).or_insert(0.0) += c.count;
                }
            }
            let want: Vec<CroppedCell> = want.into_iter().map(|(j, v)| (j / (h * w), j / w % h, j % w, v)).collect();
            assert_eq!(cropper.crop(&input, &cells, height, width), want, "bin {bin}");
        }
    }

    #[test]
    fn histogram_quantiles_have_three_significant_digits() {
        let mut h = Histogram::default();
        assert_eq!(h.quantile_ns(0.5), None);
        for ns in [1_000u64, 1_000, 1_000, 50_000] {
            h.add(ns);
        }
        let p50 = h.quantile_ns(0.5).unwrap();
        assert!((999.0..=1_001.0).contains(&p50), "{p50}");
        let p99 = h.quantile_ns(0.99).unwrap();
        assert!((49_950.0..=50_050.0).contains(&p99), "{p99}");
        let mut g = Histogram::default();
        g.merge(&h);
        g.merge(&h);
        assert_eq!(g.total(), 8);
        assert_eq!(g.quantile_ns(0.5), h.quantile_ns(0.5));
        let buckets = h.octave_buckets(4);
        assert_eq!(buckets.iter().map(|b| b.1).sum::<u64>(), 4);
        assert_eq!(buckets.len(), 2);
        assert!(buckets[0].0 <= 1_000.0 && 1_000.0 < buckets[0].0 * 2f64.powf(0.25), "{buckets:?}");
        let json = serde_json::to_value(&h).unwrap();
        assert_eq!(json["count"], 4);
        assert_eq!(json["recorded_ns_count"].as_array().unwrap().len(), 2);
    }
}
