//! Any spiking network on events: a model file or, by its HDF5 signature, a NIR graph (from
//! snnTorch, Norse or this project), loaded with what is known of how it reads its input
//! ([`load_network`]); how a camera's events map onto its input ([`InputMap`]); and every spike
//! of a run on an event file, the event-driven engine checked against the time-stepped reference
//! ([`run_events`]). A loaded network is shared; each run owns its engine state.

use crate::error::{Error, Result};
use encoders::event::Event;
use encoders::formats::{self, OpenOptions};
use learn::data::TactileEncoding;
use serde::Serialize;
use snn::engine::{Engine, Mode};
use snn::model_file::{Readout, SnnModel};
use snn::network::Network;
use snn::nir::{self, Graph, ImportOptions, ImportReset};
use std::path::Path;

/// A network ready to run on events, with what is known of how it reads its input.
#[derive(Debug, Clone)]
pub struct LoadedNetwork {
    pub network: Network,
    pub dt_us: i64,
    pub readout: Readout,
    /// A model file's tactile encoding (how a dataset folder becomes its input), if it has one.
    pub encoding: Option<TactileEncoding>,
    pub classes: Vec<String>,
    pub source: ModelSource,
}

/// Where a loaded network came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelSource {
    ModelFile,
    NirGraph,
    /// The peer benchmark's network, built in ([`peer_network`]).
    Builtin,
}

/// The peer benchmark's network (`braille bench` without `--model`: the conv SNN of
/// `scripts/peers`, 2 x 60 x 80 input, 20 steps of 1 ms), ready to run like a loaded one.
pub fn peer_network() -> LoadedNetwork {
    let network = snn::network::peers_conv(1, snn::network::PEER_GAIN);
    LoadedNetwork {
        readout: Readout::implied_by(&network),
        classes: (0..network.n_outputs()).map(|i| i.to_string()).collect(),
        dt_us: snn::network::PEER_DT_US,
        encoding: None,
        source: ModelSource::Builtin,
        network,
    }
}

/// Sample `s` of the peer benchmark's input (`braille bench` runs samples 0 to `--samples`), as
/// the events of an 80 x 60 sensor: input `(c, y, x)` of the 2 x 60 x 80 input is pixel `(x, y)`
/// with polarity `c` (OFF 0, ON 1), which [`InputMap`] maps back to the same input.
pub fn peer_sample_events(s: u64) -> Vec<Event> {
    let [_, h, w] = PEER_INPUT;
    snn::network::peer_sample(1000 + s, PEER_INPUT.iter().product())
        .into_iter()
        .map(|(t, i)| {
            let i = i as usize;
            let polarity = encoders::Polarity::from_on(i / (h * w) == 1);
            Event::new(t, (i % w) as u16, (i / w % h) as u16, polarity)
        })
        .collect()
}

/// The peer benchmark's input shape, `[channels, height, width]`.
pub const PEER_INPUT: [usize; 3] = snn::network::PEER_INPUT;

/// How a NIR graph is read: the engine's step and the neurons' reset (NIR cannot say either).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NirReading {
    pub dt_us: i64,
    pub reset: ImportReset,
}

impl Default for NirReading {
    fn default() -> Self {
        NirReading { dt_us: 100, reset: ImportReset::ToVReset }
    }
}

const HDF5_MAGIC: &[u8] = b"\x89HDF\r\n\x1a\n";

/// Loads a model file or, by its HDF5 signature, a NIR graph read as `nir` says.
pub fn load_network(path: &Path, nir: NirReading) -> Result<LoadedNetwork> {
    let mut head = [0u8; 8];
    {
        use std::io::Read;
        let mut f = std::fs::File::open(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        let n = f.read(&mut head).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        if n < head.len() {
            head[n..].fill(0);
        }
    }
    if head.starts_with(HDF5_MAGIC) {
        if nir.dt_us <= 0 {
            return Err(Error::Setting {
                name: "NIR step (us)",
                value: nir.dt_us.to_string(),
                expected: "a positive number of microseconds",
            });
        }
        let graph = Graph::read(path)?;
        let imported = nir::import(path, &graph, &ImportOptions { dt_s: nir.dt_us as f64 * 1e-6, reset: nir.reset })?;
        let network = imported.network;
        let readout = Readout::implied_by(&network);
        let classes = (0..network.n_outputs()).map(|i| i.to_string()).collect();
        return Ok(LoadedNetwork {
            network,
            dt_us: nir.dt_us,
            readout,
            encoding: None,
            classes,
            source: ModelSource::NirGraph,
        });
    }
    let model: SnnModel = crate::models::load_snn(path)?;
    let encoding = match crate::models::Preprocessing::of_header(&model.preprocess, path)? {
        crate::models::Preprocessing::Tactile(e) => Some(e),
        _ => None,
    };
    Ok(LoadedNetwork {
        network: model.network,
        dt_us: model.config.dt_us,
        readout: model.config.readout,
        encoding,
        classes: model.classes,
        source: ModelSource::ModelFile,
    })
}

/// How a camera's events map onto a network's input: `[C, H, W]` in C order, the channel the
/// polarity (OFF 0, ON 1) when `C` is 2, both polarities into one plane when `C` is 1. A flat
/// input of `n` is read as `2 x H x W` or `H x W` of the file's resolution, or, when the file
/// declares none, as `2 x 1 x n/2` (a row of taxels, as the tactile datasets lay them out).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct InputMap {
    pub channels: usize,
    pub height: usize,
    pub width: usize,
}

impl InputMap {
    /// The map of `net`'s input for events of `resolution` (if the file declares one); `path`
    /// names the file in errors.
    pub fn new(net: &Network, resolution: Option<encoders::Resolution>, path: &Path) -> Result<InputMap> {
        let n = net.n_inputs();
        let map = match net.input_shape[..] {
            [c, h, w] => InputMap { channels: c, height: h, width: w },
            [_] => match resolution {
                Some(r) if n == 2 * r.pixels() => {
                    InputMap { channels: 2, height: r.height as usize, width: r.width as usize }
                }
                Some(r) if n == r.pixels() => {
                    InputMap { channels: 1, height: r.height as usize, width: r.width as usize }
                }
                Some(r) => {
                    return Err(Error::InputsDontFitSensor {
                        path: path.to_path_buf(),
                        inputs: n,
                        width: r.width,
                        height: r.height,
                    });
                }
                None if n.is_multiple_of(2) => InputMap { channels: 2, height: 1, width: n / 2 },
                None => InputMap { channels: 1, height: 1, width: n },
            },
            ref other => return Err(Error::NotCameraInput { path: path.to_path_buf(), shape: other.to_vec() }),
        };
        if !(1..=2).contains(&map.channels) {
            return Err(Error::NotCameraInput { path: path.to_path_buf(), shape: net.input_shape.clone() });
        }
        Ok(map)
    }

    /// The input index of event number `k` of `path`, or an error naming the event.
    #[inline]
    pub fn index(&self, e: &Event, k: u64, path: &Path) -> Result<u32> {
        let (x, y) = (e.x as usize, e.y as usize);
        if x >= self.width || y >= self.height {
            return Err(Error::EventOutsideInput {
                path: path.to_path_buf(),
                index: k,
                t_us: e.t_us,
                x: e.x,
                y: e.y,
                width: self.width,
                height: self.height,
            });
        }
        let c = if self.channels == 2 { e.polarity.index() } else { 0 };
        Ok(((c * self.height + y) * self.width + x) as u32)
    }
}

/// Every spike of a network run on an event file (`braille run`), from the time-stepped
/// reference, checked against the event-driven engine's output layer.
#[derive(Debug, Clone, Serialize)]
pub struct RunRecord {
    pub steps: usize,
    /// The layers with neurons, by index in the network.
    pub layers: Vec<usize>,
    /// Per layer with neurons, per step: the neurons that spiked.
    #[serde(skip)]
    pub spikes: Vec<Vec<Vec<u32>>>,
    pub spikes_per_layer: Vec<u64>,
}

impl RunRecord {
    /// Every spike as CSV, `layer,step,neuron` (`layer` counts the layers with neurons), to `path`.
    pub fn write_spikes_csv(&self, path: &Path) -> Result<()> {
        use std::io::Write;
        let io = |source| Error::Io { path: path.to_path_buf(), source };
        let mut f = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        writeln!(f, "layer,step,neuron").map_err(io)?;
        for (k, layer) in self.spikes.iter().enumerate() {
            for (t, spiked) in layer.iter().enumerate() {
                spiked.iter().try_for_each(|j| writeln!(f, "{k},{t},{j}")).map_err(io)?;
            }
        }
        f.flush().map_err(io)
    }
}

/// Runs `net` on the events of `path` (mapped by [`InputMap`]), from time 0 for `steps` steps
/// (default: up to the last event), on the time-stepped reference and on the engine in stepped
/// mode; their output spikes must agree.
pub fn run_events(net: &LoadedNetwork, path: &Path, steps: Option<usize>) -> Result<RunRecord> {
    let (info, events) = formats::read_all(path, &OpenOptions::default())?;
    record_events(net, &events, info.resolution, path, steps)
}

/// [`run_events`] on events in memory, of a sensor of `resolution` (if known); `path` names them
/// in errors.
pub fn record_events(
    net: &LoadedNetwork,
    events: &[Event],
    resolution: Option<encoders::Resolution>,
    path: &Path,
    steps: Option<usize>,
) -> Result<RunRecord> {
    let map = InputMap::new(&net.network, resolution, path)?;
    let n = net.network.n_inputs();
    let dt = net.dt_us;
    if let Some((k, e)) = events.iter().enumerate().find(|(_, e)| e.t_us < 0) {
        return Err(Error::EventBeforeZero { path: path.to_path_buf(), index: k as u64, t_us: e.t_us });
    }
    let steps = steps.unwrap_or_else(|| events.last().map_or(0, |e| (e.t_us / dt) as usize + 1));
    let mut dense = vec![0f32; steps * n];
    let engine = Engine::new(&net.network, dt, Mode::Stepped)?;
    let mut st = engine.state(0);
    for (k, e) in events.iter().enumerate() {
        let step = (e.t_us / dt) as usize;
        if step >= steps {
            break;
        }
        let i = map.index(e, k as u64, path)?;
        dense[step * n + i as usize] += 1.0;
        engine.push(&mut st, e.t_us, i, 1.0)?;
    }
    engine.finish(&mut st, steps as i64 * dt);
    let mut record = snn::network::forward_dense(&net.network, &dense, steps)?;
    let layers: Vec<usize> =
        (0..net.network.layers.len()).filter(|&k| net.network.layers[k].neurons.is_some()).collect();
    // the reference keeps a (spikeless) entry for layers without neurons
    let spikes: Vec<Vec<Vec<u32>>> = layers.iter().map(|&k| std::mem::take(&mut record.spikes[k])).collect();
    if let Some(last) = spikes.last()
        && net.network.layers.last().is_some_and(|l| l.neurons.is_some())
    {
        let dense_out: Vec<(i64, u32)> =
            last.iter().enumerate().flat_map(|(t, s)| s.iter().map(move |&j| (t as i64 * dt, j))).collect();
        if dense_out != st.output {
            return Err(Error::EngineDisagrees {
                path: path.to_path_buf(),
                engine_spikes: st.output.len(),
                reference_spikes: dense_out.len(),
            });
        }
    }
    Ok(RunRecord {
        steps,
        spikes_per_layer: spikes.iter().map(|l| l.iter().map(|s| s.len() as u64).sum()).collect(),
        layers,
        spikes,
    })
}

/// The SNN of the model file at `path` as a NIR graph, checked against `target`'s rules and written
/// in `convention` (how a peer's importer reads time constants); neurons that reset by subtraction
/// are refused unless `subtract_as_reset` writes them as NIR's reset. Returns the graph and the
/// model's step in seconds.
pub fn export_nir(
    path: &Path,
    target: snn::nir::Target,
    convention: snn::nir::Convention,
    subtract_as_reset: bool,
) -> Result<(Graph, f64)> {
    use snn::nir::{ExportOptions, SubtractExport};
    let at = |e: snn::Error, prefix: &str| Error::Model {
        path: path.to_path_buf(),
        what: e.to_string().trim_start_matches(prefix).to_string(),
    };
    let model = crate::models::load_snn(path)?;
    nir::check_target(&model.network, target).map_err(|e| at(e, "<target>: "))?;
    let dt_s = model.config.dt_us as f64 * 1e-6;
    let subtract = if subtract_as_reset { SubtractExport::AsReset } else { SubtractExport::Refuse };
    let graph =
        nir::export(&model.network, &ExportOptions { dt_s, subtract, convention }).map_err(|e| at(e, "<export>: "))?;
    Ok((graph, dt_s))
}

/// Which NIR nodes became each layer of an imported network: (operation, neurons if any).
pub type LayerNodes = Vec<(String, Option<String>)>;

/// A NIR graph as a model file the engine runs, at step `dt_us` with `reset` (NIR says neither).
/// `like` gives it a model's input encoding, classes and operating point (a twin reads as its
/// model does); without it the classes are the output indices. Returns the model, the NIR nodes
/// of each layer and the graph.
pub fn import_nir(
    file: &Path,
    dt_us: i64,
    reset: ImportReset,
    like: Option<&Path>,
) -> Result<(SnnModel, LayerNodes, Graph)> {
    if dt_us <= 0 {
        return Err(Error::Setting { name: "dt_us", value: dt_us.to_string(), expected: "a positive step" });
    }
    let graph = Graph::read(file)?;
    let imported = nir::import(file, &graph, &ImportOptions { dt_s: dt_us as f64 * 1e-6, reset })?;
    let net = imported.network;
    let readout = Readout::implied_by(&net);
    let (preprocess, classes, operating_point) = match like {
        Some(p) => {
            let m = crate::models::load_snn(p)?;
            (m.preprocess, m.classes, m.operating_point)
        }
        None => (serde_json::Value::Null, (0..net.n_outputs()).map(|i| i.to_string()).collect(), None),
    };
    let model = SnnModel {
        config: snn::model_file::SnnConfig { network: net.spec(), dt_us, readout },
        network: net,
        preprocess,
        classes,
        provenance: serde_json::json!({ "imported_from": file.display().to_string(), "nir_version": graph.version }),
        operating_point,
    };
    Ok((model, imported.layer_nodes, graph))
}
