//! Networks on the event-driven engine: a loaded model (parameters, shared by every call and
//! thread) and a pool of engine states (each run owns one while it runs).

use crate::errors::{BrailleError, OrPy, choice, name_of, to_python};
use crate::events::{TonicEvent, events_of, resolution_of, to_array, tonic_events};
use encoders::{Event, Resolution};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pipeline::network::{self as model_bench, InputMap, LoadedNetwork, ModelSource, NirReading};
use pyo3::prelude::*;
use rayon::prelude::*;
use snn::chip::xylo::{Quantisation, Run};
use snn::chip::{Chip, ChipModel};
use snn::engine::{Engine, EngineState, Mode};
use snn::model_file::Readout;
use snn::nir::{self, Convention, ExportOptions, ImportReset, SubtractExport, Target};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A spiking network on the event-driven engine: a model file, a NIR graph or the peer
/// benchmark's network. Loaded once, shared by every call and thread; each run owns its own
/// engine state.
#[pyclass(frozen, module = "neurobraille")]
pub struct Network {
    net: Arc<LoadedNetwork>,
    name: String,
    /// The compiled engine per mode (stepped, async), built on first use.
    engines: Mutex<[Option<Arc<Engine>>; 2]>,
    /// Engine states no run holds, per mode.
    pool: Mutex<[Vec<EngineState>; 2]>,
    /// The network mapped into a chip's formats, per chip and quantiser, built on first use.
    chips: Mutex<Vec<MappedChip>>,
}

/// A network mapped into a chip's formats, and by which quantiser.
type MappedChip = ((Chip, Quantisation), Arc<ChipModel>);

/// What one run of a sample gives.
#[pyclass(frozen, get_all, module = "neurobraille")]
pub struct RunResult {
    /// Per output: the highest membrane (leaky-integrator outputs) or the spike count.
    readout: Py<PyArray1<f32>>,
    /// The output with the highest readout (the first of equals).
    prediction: usize,
    /// Its class name.
    label: String,
    /// Spikes of each layer with neurons.
    spikes_per_layer: Vec<u64>,
    /// Synaptic operations (one weight added to one target).
    synops: u64,
    input_events: u64,
    /// Output spikes as rows `(t_us, neuron)`: in stepped mode `t_us` is the step's start.
    output_spikes: Py<PyArray2<i64>>,
    /// With `latency=True`: each input event's push in nanoseconds (clock included), else None.
    latency_ns: Option<Py<PyArray1<u64>>>,
}

#[pymethods]
impl RunResult {
    fn __repr__(&self) -> String {
        format!(
            "RunResult(prediction={}, label={:?}, spikes_per_layer={:?}, synops={}, input_events={})",
            self.prediction, self.label, self.spikes_per_layer, self.synops, self.input_events
        )
    }
}

/// A run's outcome before it becomes Python objects.
struct Outcome {
    readout: Vec<f32>,
    spikes_per_layer: Vec<u64>,
    synops: u64,
    input_events: u64,
    output: Vec<(i64, u32)>,
    latency_ns: Option<Vec<u64>>,
}

fn mode_index(mode: Mode) -> usize {
    match mode {
        Mode::Stepped => 0,
        Mode::Async => 1,
    }
}

/// Refuses inputs whose first event comes before the stream's start.
fn starts_after(inputs: &[(i64, u32)], t_start_us: i64, what: &str) -> PyResult<()> {
    match inputs.first() {
        Some(&(t, _)) if t < t_start_us => Err(BrailleError::new_err(format!(
            "{what}[0]: t = {t} us is before the stream's start, t_start_us = {t_start_us}"
        ))),
        _ => Ok(()),
    }
}

/// A sample's events as the engine's inputs `(t_us, input)`.
fn inputs_of(
    net: &LoadedNetwork,
    events: &[Event],
    resolution: Option<Resolution>,
    what: &str,
) -> PyResult<Vec<(i64, u32)>> {
    let name = Path::new(what);
    let map = InputMap::new(&net.network, resolution, name).or_py()?;
    events.iter().enumerate().map(|(k, e)| Ok((e.t_us, map.index(e, k as u64, name).or_py()?))).collect()
}

impl Network {
    fn new(net: LoadedNetwork, name: String) -> Network {
        Network {
            net: Arc::new(net),
            name,
            engines: Mutex::new([None, None]),
            pool: Mutex::new([Vec::new(), Vec::new()]),
            chips: Mutex::new(Vec::new()),
        }
    }

    /// The network in `chip`'s formats, quantised by `q` (mapped once, then shared).
    fn chip(&self, chip: Chip, q: Quantisation) -> PyResult<Arc<ChipModel>> {
        let mut chips = self.chips.lock().expect("chip cache poisoned");
        if let Some((_, x)) = chips.iter().find(|(k, _)| *k == (chip, q)) {
            return Ok(x.clone());
        }
        let mapped = ChipModel::map(&self.net.network, chip, q, self.net.readout)
            .map_err(|e| BrailleError::new_err(format!("{}: {e}", self.name)))?;
        let x = Arc::new(mapped.model);
        chips.push(((chip, q), x.clone()));
        Ok(x)
    }

    /// Runs one sample in a chip's arithmetic: the inputs binned into the network's steps from
    /// `t_start_us` to `t_end_us` (events of one input in one step counted), each step as the
    /// chip computes it.
    fn run_chip_inputs(
        &self,
        chip: &ChipModel,
        inputs: &[(i64, u32)],
        t_start_us: i64,
        t_end_us: Option<i64>,
        run: Run,
        what: &str,
    ) -> PyResult<Outcome> {
        starts_after(inputs, t_start_us, what)?;
        let dt = self.net.dt_us;
        let t_end = t_end_us.unwrap_or_else(|| inputs.last().map_or(t_start_us, |e| e.0) + 1);
        let steps = ((t_end - t_start_us).max(0) + dt - 1) / dt;
        let n_in = chip.n_in();
        let mut st = chip.state();
        let (mut counts, mut channels, mut events) = (vec![0u16; n_in], Vec::new(), Vec::new());
        let mut output = Vec::new();
        let mut next = 0;
        for k in 0..steps {
            let end = t_start_us + (k + 1) * dt;
            channels.clear();
            events.clear();
            while next < inputs.len() && inputs[next].0 < end {
                let i = inputs[next].1 as usize;
                if counts[i] == 0 {
                    channels.push(i as u32);
                }
                counts[i] = counts[i].saturating_add(1);
                next += 1;
            }
            channels.sort_unstable();
            for &c in &channels {
                events.push(counts[c as usize]);
                counts[c as usize] = 0;
            }
            chip.step(&mut st, &channels, &events, run).map_err(|e| BrailleError::new_err(format!("{what}: {e}")))?;
            for (j, _) in chip.out_spikes(&st) {
                output.push((t_start_us + k * dt, j as u32));
            }
        }
        // Loihi 2 answers its last input a step per layer later: the window runs on, without input
        for k in steps..steps + chip.drain_steps() as i64 {
            chip.step(&mut st, &[], &[], run).map_err(|e| BrailleError::new_err(format!("{what}: {e}")))?;
            for (j, _) in chip.out_spikes(&st) {
                output.push((t_start_us + k * dt, j as u32));
            }
        }
        let work = ChipModel::work(&st);
        // per layer of the network, as the engine counts them (layers without neurons count 0):
        // Xylo's hidden and output neurons, or each Speck core's (Loihi 2 layer's) spikes at its
        // layer of neurons
        let spikes_per_layer = match chip {
            ChipModel::Xylo(_) => work.spikes_per_layer.clone(),
            ChipModel::Speck(_) | ChipModel::Loihi2(_) => {
                let mut cores = work.spikes_per_layer.iter();
                self.net
                    .network
                    .layers
                    .iter()
                    .map(|l| if l.neurons.is_some() { cores.next().copied().unwrap_or(0) } else { 0 })
                    .collect()
            }
        };
        Ok(Outcome {
            readout: chip.readout(&st),
            spikes_per_layer,
            synops: work.synops,
            input_events: work.input_events,
            output,
            latency_ns: None,
        })
    }

    fn engine(&self, mode: Mode) -> PyResult<Arc<Engine>> {
        let mut engines = self.engines.lock().expect("engine cache poisoned");
        let slot = &mut engines[mode_index(mode)];
        if let Some(e) = slot {
            return Ok(e.clone());
        }
        let e = Arc::new(Engine::new(&self.net.network, self.net.dt_us, mode).map_err(|e| {
            BrailleError::new_err(format!(
                "{}: {e}{}",
                self.name,
                if mode == Mode::Async {
                    " (async mode runs LIF and IF layers without bias or recurrence; use mode=\"stepped\")"
                } else {
                    ""
                }
            ))
        })?);
        *slot = Some(e.clone());
        Ok(e)
    }

    fn take_state(&self, engine: &Engine) -> EngineState {
        let mut pool = self.pool.lock().expect("state pool poisoned");
        pool[mode_index(engine.mode())].pop().unwrap_or_else(|| engine.state(0))
    }

    fn give_state(&self, engine: &Engine, st: EngineState) {
        self.pool.lock().expect("state pool poisoned")[mode_index(engine.mode())].push(st);
    }

    /// Runs one sample on a pooled state; no Python object is touched.
    fn run_inputs(
        &self,
        engine: &Engine,
        inputs: &[(i64, u32)],
        t_start_us: i64,
        t_end_us: Option<i64>,
        latency: bool,
        what: &str,
    ) -> PyResult<Outcome> {
        starts_after(inputs, t_start_us, what)?;
        let t_end = t_end_us.unwrap_or_else(|| inputs.last().map_or(t_start_us, |e| e.0) + 1);
        let mut st = self.take_state(engine);
        engine.reset(&mut st, t_start_us);
        let mut lat = latency.then(|| Vec::with_capacity(inputs.len()));
        let pushed = (|| -> snn::Result<()> {
            match &mut lat {
                Some(lat) => {
                    for &(t, i) in inputs {
                        let t0 = Instant::now();
                        engine.push(&mut st, t, i, 1.0)?;
                        lat.push((t0.elapsed().as_nanos() as u64).max(1));
                    }
                }
                None => {
                    for &(t, i) in inputs {
                        engine.push(&mut st, t, i, 1.0)?;
                    }
                }
            }
            Ok(())
        })();
        if let Err(e) = pushed {
            self.give_state(engine, st);
            return Err(BrailleError::new_err(format!("{what}: {e}")));
        }
        engine.finish(&mut st, t_end);
        let readout = match self.net.readout {
            Readout::MaxMembrane => st.output_v_max().to_vec(),
            Readout::SpikeCount => st.output_counts(engine.n_outputs()).into_iter().map(|c| c as f32).collect(),
        };
        let out = Outcome {
            readout,
            spikes_per_layer: st.stats.spikes.clone(),
            synops: st.stats.synops,
            input_events: st.stats.input_events,
            output: st.output.clone(),
            latency_ns: lat,
        };
        self.give_state(engine, st);
        Ok(out)
    }

    fn check_target(&self, target: Target) -> PyResult<()> {
        nir::check_target(&self.net.network, target).map_err(|e| {
            BrailleError::new_err(format!("{}: {}", self.name, e.to_string().trim_start_matches("<target>: ")))
        })
    }

    fn result(&self, py: Python<'_>, o: Outcome) -> PyResult<RunResult> {
        let prediction = pipeline::classify::argmax(o.readout.iter().copied());
        let rows: Vec<Vec<i64>> = o.output.iter().map(|&(t, j)| vec![t, j as i64]).collect();
        let output_spikes = if rows.is_empty() {
            PyArray2::<i64>::zeros(py, [0, 2], false)
        } else {
            PyArray2::from_vec2(py, &rows).map_err(|e| BrailleError::new_err(e.to_string()))?
        };
        // layers without neurons count 0 in the engine; report the layers with neurons
        let spikes_per_layer = self
            .net
            .network
            .layers
            .iter()
            .zip(&o.spikes_per_layer)
            .filter(|(l, _)| l.neurons.is_some())
            .map(|(_, &s)| s)
            .collect();
        Ok(RunResult {
            label: self.net.classes.get(prediction).cloned().unwrap_or_default(),
            prediction,
            readout: PyArray1::from_vec(py, o.readout).unbind(),
            spikes_per_layer,
            synops: o.synops,
            input_events: o.input_events,
            output_spikes: output_spikes.unbind(),
            latency_ns: o.latency_ns.map(|l| PyArray1::from_vec(py, l).unbind()),
        })
    }
}

#[pymethods]
impl Network {
    /// Loads a model file (`.safetensors` from `braille train`) or, by its HDF5 signature, a NIR
    /// graph. NIR says neither the step nor how neurons reset: `dt_us` and `reset`
    /// ("to-v-reset", NIR's own, or "subtract") say it for a graph; a model file carries
    /// its own.
    #[staticmethod]
    #[pyo3(signature = (path, dt_us=100, reset="to-v-reset"))]
    fn load(py: Python<'_>, path: PathBuf, dt_us: i64, reset: &str) -> PyResult<Network> {
        let reset: ImportReset = choice("reset", reset)?;
        let net = py.detach(|| model_bench::load_network(&path, NirReading { dt_us, reset })).or_py()?;
        Ok(Network::new(net, path.display().to_string()))
    }

    /// Where the network came from: "model_file", "nir_graph" or "builtin".
    #[getter]
    fn source(&self) -> &'static str {
        match self.net.source {
            ModelSource::ModelFile => "model_file",
            ModelSource::NirGraph => "nir_graph",
            ModelSource::Builtin => "builtin",
        }
    }

    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    #[getter]
    fn dt_us(&self) -> i64 {
        self.net.dt_us
    }

    #[getter]
    fn n_inputs(&self) -> usize {
        self.net.network.n_inputs()
    }

    #[getter]
    fn n_outputs(&self) -> usize {
        self.net.network.n_outputs()
    }

    /// The input's shape: `[channels, height, width]`, or `[n]` for a flat input.
    #[getter]
    fn input_shape(&self) -> Vec<usize> {
        self.net.network.input_shape.clone()
    }

    #[getter]
    fn classes(&self) -> Vec<String> {
        self.net.classes.clone()
    }

    /// "max-membrane" (leaky-integrator outputs) or "spike-count".
    #[getter]
    fn readout(&self) -> String {
        name_of(&self.net.readout)
    }

    /// The layers, as the model file's header describes them.
    #[getter]
    fn spec<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.net.network.spec())
    }

    /// Runs one sample's events (a structured array with fields x, y, t, p) on the engine and
    /// returns the readout, the prediction, spikes per layer, SynOps and, with `latency`, each
    /// event's push time in nanoseconds.
    ///
    /// Events map onto the input as `braille bench --model` maps them: a `[C, H, W]` input takes
    /// pixel (x, y) with channel = polarity (C = 2) or both polarities in one plane (C = 1); a
    /// flat input of n takes `sensor_size`'s 2 x H x W or H x W, or, without `sensor_size`, a row
    /// of n/2 taxels with OFF and ON. The stream starts at `t_start_us` (step 0) and runs to
    /// `t_end_us` [default: just past the last event]. `mode`: "stepped" (exactly the
    /// time-stepped network) or "async" (each event's effects complete at once).
    ///
    /// `chip="xylo"`, `chip="speck"` or `chip="loihi2"` runs the sample in that chip's
    /// arithmetic instead (docs/chips.md): the network mapped into its number formats by
    /// `quantisation` ("global" or "channel", Rockpool's quantisers on Xylo; Speck and Loihi 2
    /// take "global", one scale per core or layer), the events counted per input and step, every
    /// step as the chip computes it (on Loihi 2, then one step per layer without input, its
    /// latency); `mode` is then "stepped" (every neuron every step) or "event-driven" (only
    /// neurons with state or input), bit for bit the same. `spikes_per_layer` is then Xylo's
    /// hidden and output neurons' spikes or each Speck core's or Loihi 2 layer's, `input_events`
    /// those the chip took (at most 15 per input and step on Xylo).
    #[pyo3(signature = (events, mode="stepped", sensor_size=None, t_start_us=0, t_end_us=None, latency=false, chip=None, quantisation="global"))]
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        py: Python<'_>,
        events: &Bound<'_, PyAny>,
        mode: &str,
        sensor_size: Option<Vec<i64>>,
        t_start_us: i64,
        t_end_us: Option<i64>,
        latency: bool,
        chip: Option<&str>,
        quantisation: &str,
    ) -> PyResult<RunResult> {
        let resolution = resolution_of("sensor_size", sensor_size)?;
        if let Some(chip) = chip {
            let chip: Chip = choice("chip", chip)?;
            let run: Run = choice("mode", mode)?;
            let q: Quantisation = choice("quantisation", quantisation)?;
            if latency {
                return Err(BrailleError::new_err("latency=True times the float engine's pushes; not with chip="));
            }
            let x = self.chip(chip, q)?;
            let inputs = inputs_of(&self.net, &events_of(events, "events")?, resolution, "events")?;
            let o = py.detach(|| self.run_chip_inputs(&x, &inputs, t_start_us, t_end_us, run, "events"))?;
            return self.result(py, o);
        }
        let mode: Mode = choice("mode", mode)?;
        let engine = self.engine(mode)?;
        let inputs = if let Ok(a) = events.cast::<PyArray1<TonicEvent>>() {
            // the common case, read in place: no intermediate list of events
            let a = a.readonly();
            let map = InputMap::new(&self.net.network, resolution, Path::new("events")).or_py()?;
            let mut inputs = Vec::with_capacity(a.len()?);
            let mut last = i64::MIN;
            for (k, e) in a.as_array().iter().enumerate() {
                let e = e.event();
                if e.t_us < last {
                    return Err(BrailleError::new_err(format!(
                        "events[{k}]: t = {} us comes before the previous event's {last} us (events must be in time order)",
                        e.t_us
                    )));
                }
                last = e.t_us;
                inputs.push((e.t_us, map.index(&e, k as u64, Path::new("events")).or_py()?));
            }
            inputs
        } else {
            inputs_of(&self.net, &events_of(events, "events")?, resolution, "events")?
        };
        let o = py.detach(|| self.run_inputs(&engine, &inputs, t_start_us, t_end_us, latency, "events"))?;
        self.result(py, o)
    }

    /// Runs many samples, in parallel on all cores with the GIL released, each on its own engine
    /// state; the results in the samples' order. Arguments as for `run`.
    #[pyo3(signature = (samples, mode="stepped", sensor_size=None, t_start_us=0, t_end_us=None))]
    fn run_batch(
        &self,
        py: Python<'_>,
        samples: Vec<Bound<'_, PyAny>>,
        mode: &str,
        sensor_size: Option<Vec<i64>>,
        t_start_us: i64,
        t_end_us: Option<i64>,
    ) -> PyResult<Vec<RunResult>> {
        let mode: Mode = choice("mode", mode)?;
        let resolution = resolution_of("sensor_size", sensor_size)?;
        let engine = self.engine(mode)?;
        let inputs = samples
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let what = format!("samples[{k}]");
                inputs_of(&self.net, &events_of(s, &what)?, resolution, &what)
            })
            .collect::<PyResult<Vec<_>>>()?;
        let outcomes: Vec<PyResult<Outcome>> = py.detach(|| {
            inputs
                .par_iter()
                .enumerate()
                .map(|(k, s)| self.run_inputs(&engine, s, t_start_us, t_end_us, false, &format!("samples[{k}]")))
                .collect()
        });
        outcomes.into_iter().map(|o| self.result(py, o?)).collect()
    }

    /// Every spike of every layer with neurons, as `braille run` writes them: from time 0 for
    /// `steps` steps [default: up to the last event], on the time-stepped reference, checked
    /// against the engine's output layer. Returns `{"steps", "layers", "spikes"}`, `spikes` a
    /// list per layer of int64 arrays of rows `(step, neuron)`.
    #[pyo3(signature = (events, sensor_size=None, steps=None))]
    fn record<'py>(
        &self,
        py: Python<'py>,
        events: &Bound<'py, PyAny>,
        sensor_size: Option<Vec<i64>>,
        steps: Option<usize>,
    ) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let resolution = resolution_of("sensor_size", sensor_size)?;
        let events = events_of(events, "events")?;
        let r = py
            .detach(|| model_bench::record_events(&self.net, &events, resolution, Path::new("events"), steps))
            .or_py()?;
        let d = pyo3::types::PyDict::new(py);
        d.set_item("steps", r.steps)?;
        d.set_item("layers", r.layers.clone())?;
        let spikes = r
            .spikes
            .iter()
            .map(|layer| {
                let rows: Vec<i64> = layer
                    .iter()
                    .enumerate()
                    .flat_map(|(t, s)| s.iter().flat_map(move |&j| [t as i64, j as i64]))
                    .collect();
                let n = rows.len() / 2;
                PyArray1::from_vec(py, rows).reshape([n, 2])
            })
            .collect::<PyResult<Vec<_>>>()?;
        d.set_item("spikes", spikes)?;
        Ok(d)
    }

    /// Checks the network against a chip's rules ("generic", "loihi2", "speck", "xylo",
    /// "spinnaker2"); raises BrailleError naming every rule it breaks.
    #[pyo3(signature = (target))]
    fn check(&self, target: &str) -> PyResult<()> {
        self.check_target(choice("target", target)?)
    }

    /// Exports the network to a NIR graph (HDF5) after checking it against `target`'s rules.
    /// `convention`: "nir" (NIR's own equations), "snntorch" or "norse" (what their importers
    /// read correctly). Neurons that reset by subtraction cannot be encoded in NIR: they are
    /// refused unless `subtract_as_reset` (then written as a reset to zero, which changes the
    /// network). Returns the step the graph is to be imported at, in seconds.
    #[pyo3(signature = (path, target="generic", convention="nir", subtract_as_reset=false, overwrite=false))]
    fn export(
        &self,
        py: Python<'_>,
        path: PathBuf,
        target: &str,
        convention: &str,
        subtract_as_reset: bool,
        overwrite: bool,
    ) -> PyResult<f64> {
        let target: Target = choice("target", target)?;
        let convention: Convention = choice("convention", convention)?;
        self.check_target(target)?;
        let dt_s = self.net.dt_us as f64 * 1e-6;
        let subtract = if subtract_as_reset { SubtractExport::AsReset } else { SubtractExport::Refuse };
        let graph = nir::export(&self.net.network, &ExportOptions { dt_s, subtract, convention }).map_err(|e| {
            BrailleError::new_err(format!("{}: {}", self.name, e.to_string().trim_start_matches("<export>: ")))
        })?;
        py.detach(|| graph.write(&path, overwrite)).or_py()?;
        Ok(convention.import_dt_s(dt_s))
    }

    fn __repr__(&self) -> String {
        format!(
            "Network({:?}, source={}, input_shape={:?}, n_outputs={}, dt_us={}, readout={})",
            self.name,
            self.source(),
            self.net.network.input_shape,
            self.net.network.n_outputs(),
            self.net.dt_us,
            self.readout()
        )
    }
}

/// The peer benchmark's network and input (`braille bench` without `--model`): the conv SNN of
/// `scripts/peers` (2 x 60 x 80 -> conv 5x5/2 (8) -> LIF -> conv 3x3/2 (16) -> LIF -> dense 26
/// -> LIF, 1 ms steps) and `samples` random samples of 20 steps, each as events of an 80 x 60
/// sensor (polarity = input channel). Run each with `t_end_us=20_000` for `braille bench`'s work.
#[pyfunction]
#[pyo3(signature = (samples=64))]
pub fn peer_benchmark(py: Python<'_>, samples: u64) -> PyResult<(Network, Vec<Bound<'_, PyArray1<TonicEvent>>>)> {
    let net = Network::new(model_bench::peer_network(), "the peer benchmark's network".into());
    let arrays = (0..samples).map(|s| to_array(py, tonic_events(&model_bench::peer_sample_events(s)))).collect();
    Ok((net, arrays))
}
