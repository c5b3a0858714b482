//! NIR, the Neuromorphic Intermediate Representation (<https://neuroir.org>), in and out: the
//! HDF5 files that snnTorch, Norse, Sinabs, Lava and the chips' toolchains read and write.
//!
//! # Conventions (NIR is continuous-time; the engine runs steps of `dt`)
//! - Import at step `dt` (seconds) by forward Euler, as snnTorch, Norse and NIR's reference do:
//!   `beta = 1 - dt / tau_mem`, `alpha = 1 - dt / tau_syn`, computed in f64 and cast to f32. The
//!   input scales `r * dt / tau_mem` (LIF, LI, CubaLIF) and `w_in * dt / tau_syn` (CubaLIF) are
//!   folded into the incoming weights and biases (they are exactly 1 in files from snnTorch).
//!   IF integrates `v += r * u`.
//! - Export inverts this: `tau = dt / (1 - beta)`, `r = tau / dt` (`w_in = tau_syn / dt`), so any
//!   Euler importer at the same `dt` recovers the trained `beta` and `alpha`. Parameters are
//!   written per neuron (full-shape float32), as snnTorch does, so that shapes type-check.
//! - NIR's neurons reset to `v_reset`. Reset by subtraction cannot be written in NIR; importing
//!   takes it as an out-of-band option, exporting a subtracting network is refused unless the
//!   caller accepts that the file resets to `v_reset`.
//! - One step: every node in graph order, incoming edges summed; a recurrent edge (one that
//!   closes a cycle) carries the previous step's spikes and is absent, bias included, at `t = 0`.
//! - Supported nodes: Input, Output, Affine, Linear, Conv2d (no dilation, one group), SumPool2d,
//!   AvgPool2d (no padding), Flatten (C order), LIF, CubaLIF, IF, LI. Per-neuron parameters must
//!   be equal across a layer (the engine keeps one set per layer).

use crate::error::{Error, Result};
use crate::network::{Layer, Network, Op, PoolKind};
use crate::neuron::{NeuronKind, NeuronParams, Reset};
use hdf5_pure::{File, FileBuilder};
use std::collections::BTreeMap;
use std::path::Path;

/// The NIR version written.
pub const NIR_VERSION: &str = "1.0.8";

/// A tensor of a NIR node.
#[derive(Debug, Clone, PartialEq)]
pub struct Array {
    pub shape: Vec<usize>,
    pub data: Vec<f64>,
}

impl Array {
    fn scalar(v: f64) -> Array {
        Array { shape: Vec::new(), data: vec![v] }
    }
    fn full(shape: &[usize], v: f64) -> Array {
        Array { shape: shape.to_vec(), data: vec![v; shape.iter().product::<usize>().max(1)] }
    }
    fn f32s(&self) -> Vec<f32> {
        self.data.iter().map(|&v| v as f32).collect()
    }
}

/// A node: its NIR type and its parameters by name.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    pub kind: String,
    pub params: BTreeMap<String, Array>,
}

/// A NIR graph.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Graph {
    pub version: String,
    pub nodes: BTreeMap<String, Node>,
    pub edges: Vec<(String, String)>,
}

fn nir_err(path: &Path, what: impl Into<String>) -> Error {
    Error::Model { path: path.to_path_buf(), what: what.into() }
}

impl Graph {
    /// Reads a NIR file.
    pub fn read(path: &Path) -> Result<Graph> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        Graph::parse(path, bytes)
    }

    /// Reads NIR bytes; `path` names them in errors.
    pub fn parse(path: &Path, bytes: Vec<u8>) -> Result<Graph> {
        if !hdf5_pure::is_hdf5_bytes(&bytes) {
            return Err(nir_err(path, "not a NIR file: no HDF5 signature"));
        }
        let f = File::from_bytes(bytes).map_err(|e| nir_err(path, format!("HDF5: {e}")))?;
        let text = |ds: &str| -> Result<String> {
            let d = f.dataset(ds).map_err(|e| nir_err(path, format!("`{ds}`: {e}")))?;
            let v = d.read_string().map_err(|e| nir_err(path, format!("`{ds}`: {e}")))?;
            v.into_iter().next().ok_or_else(|| nir_err(path, format!("`{ds}` is empty")))
        };
        let version = text("version").unwrap_or_default();
        let kind = text("node/type")?;
        if kind != "NIRGraph" {
            return Err(nir_err(path, format!("`node/type` is `{kind}`, not `NIRGraph`")));
        }
        let edges_ds = f.dataset("node/edges").map_err(|e| nir_err(path, format!("`node/edges`: {e}")))?;
        check_size(path, "node/edges", &edges_ds.shape().map_err(|e| nir_err(path, format!("`node/edges`: {e}")))?)?;
        let flat = edges_ds.read_string().map_err(|e| nir_err(path, format!("`node/edges`: {e}")))?;
        if flat.len() % 2 != 0 {
            return Err(nir_err(path, "`node/edges` is not a list of pairs"));
        }
        let edges = flat.chunks_exact(2).map(|p| (p[0].clone(), p[1].clone())).collect();
        let nodes_g = f.group("node/nodes").map_err(|e| nir_err(path, format!("`node/nodes`: {e}")))?;
        let names = nodes_g.groups().map_err(|e| nir_err(path, format!("`node/nodes`: {e}")))?;
        let mut nodes = BTreeMap::new();
        for name in names {
            let at = format!("node/nodes/{name}");
            let g = f.group(&at).map_err(|e| nir_err(path, format!("`{at}`: {e}")))?;
            let kind = text(&format!("{at}/type"))?;
            let mut params = BTreeMap::new();
            for ds in g.datasets().map_err(|e| nir_err(path, format!("`{at}`: {e}")))? {
                if ds == "type" {
                    continue;
                }
                let d = g.dataset(&ds).map_err(|e| nir_err(path, format!("`{at}/{ds}`: {e}")))?;
                let shape = d.shape().map_err(|e| nir_err(path, format!("`{at}/{ds}`: {e}")))?;
                check_size(path, &format!("{at}/{ds}"), &shape)?;
                let Ok(data) = d.read_f64() else { continue }; // strings and other non-numbers
                params.insert(ds, Array { shape: shape.iter().map(|&s| s as usize).collect(), data });
            }
            // NIR 1.0 keeps Input/Output shapes in `shape`; older files also in `*_type/*`.
            for (group, key) in [("input_type", "input"), ("output_type", "output")] {
                if !params.contains_key("shape")
                    && let Ok(d) = f.dataset(&format!("{at}/{group}/{key}"))
                    && let Ok(shape) = d.shape()
                    && check_size(path, &format!("{at}/{group}/{key}"), &shape).is_ok()
                    && let Ok(data) = d.read_f64()
                {
                    params.insert(format!("{group}.{key}"), Array { shape: vec![data.len()], data });
                }
            }
            nodes.insert(name, Node { kind, params });
        }
        Ok(Graph { version, nodes, edges })
    }

    /// Writes the graph (HDF5, the layout `nir.write` produces) atomically; an existing file is
    /// kept unless `force`.
    pub fn write(&self, path: &Path, force: bool) -> Result<()> {
        let mut b = FileBuilder::new();
        b.create_dataset("version").with_vlen_strings(&[NIR_VERSION]).with_shape(&[]);
        let mut node = b.create_group("node");
        node.create_dataset("type").with_vlen_strings(&["NIRGraph"]).with_shape(&[]);
        let flat: Vec<&str> = self.edges.iter().flat_map(|(a, b)| [a.as_str(), b.as_str()]).collect();
        node.create_dataset("edges").with_vlen_strings(&flat).with_shape(&[self.edges.len() as u64, 2]);
        let mut nodes = node.create_group("nodes");
        for (name, n) in &self.nodes {
            let mut g = nodes.create_group(name);
            g.create_dataset("type").with_vlen_strings(&[n.kind.as_str()]).with_shape(&[]);
            for (k, a) in &n.params {
                let shape: Vec<u64> = a.shape.iter().map(|&s| s as u64).collect();
                if is_integer_param(k) {
                    let v: Vec<i64> = a.data.iter().map(|&x| x as i64).collect();
                    g.create_dataset(k).with_i64_data(&v).with_shape(&shape);
                } else {
                    g.create_dataset(k).with_f32_data(&a.f32s()).with_shape(&shape);
                }
            }
            nodes.add_group(g.finish());
        }
        node.add_group(nodes.finish());
        b.add_group(node.finish());
        let bytes = b.finish().map_err(|e| nir_err(path, format!("HDF5: {e}")))?;
        crate::model_file::write_atomic(path, &bytes, force)
    }
}

fn is_integer_param(k: &str) -> bool {
    matches!(
        k,
        "shape"
            | "stride"
            | "padding"
            | "dilation"
            | "groups"
            | "input_shape"
            | "kernel_size"
            | "start_dim"
            | "end_dim"
            | "input_type"
    )
}

/// How an imported graph resets its neurons (NIR cannot say; its nodes reset to `v_reset`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ImportReset {
    /// NIR's semantics.
    #[default]
    ToVReset,
    /// Reset by subtraction (what snnTorch's `subtract` means; NIR cannot say it).
    Subtract,
}

/// Options of an import.
#[derive(Debug, Clone, Copy)]
pub struct ImportOptions {
    /// The engine's step, in seconds.
    pub dt_s: f64,
    pub reset: ImportReset,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self { dt_s: 1e-4, reset: ImportReset::ToVReset }
    }
}

/// A parameter that must be one value across a layer.
fn uniform(path: &Path, name: &str, node: &Node, key: &str, default: Option<f64>) -> Result<f64> {
    match node.params.get(key) {
        None => {
            default.ok_or_else(|| nir_err(path, format!("node `{name}` ({}): parameter `{key}` is missing", node.kind)))
        }
        Some(a) => {
            let first = *a.data.first().ok_or_else(|| nir_err(path, format!("node `{name}`: `{key}` is empty")))?;
            if let Some(i) = a.data.iter().position(|&v| v != first) {
                return Err(nir_err(
                    path,
                    format!(
                        "node `{name}` ({}): `{key}` differs across neurons ({first} and {} at {i}); the engine keeps one value per layer",
                        node.kind, a.data[i]
                    ),
                ));
            }
            if !first.is_finite() {
                return Err(nir_err(path, format!("node `{name}`: `{key}` is {first}")));
            }
            Ok(first)
        }
    }
}

fn pair(path: &Path, name: &str, node: &Node, key: &str, default: usize) -> Result<[usize; 2]> {
    match node.params.get(key) {
        None => Ok([default; 2]),
        Some(a) => {
            let v: Vec<usize> = a.data.iter().map(|&x| x as usize).collect();
            match v.as_slice() {
                [x] => Ok([*x, *x]),
                [y, x] => Ok([*y, *x]),
                _ => {
                    Err(nir_err(path, format!("node `{name}`: `{key}` should be a scalar or a pair, got {:?}", a.data)))
                }
            }
        }
    }
}

fn is_neuron(kind: &str) -> bool {
    matches!(kind, "LIF" | "CubaLIF" | "IF" | "LI")
}

/// The neuron parameters of `node` at step `dt`, and the scale of its input.
fn neuron(path: &Path, name: &str, node: &Node, opts: &ImportOptions) -> Result<(NeuronParams, f64)> {
    let dt = opts.dt_s;
    let get = |k: &str, d: Option<f64>| uniform(path, name, node, k, d);
    let factor = |tau: f64| -> Result<f64> {
        if tau <= 0.0 || dt / tau > 1.0 {
            return Err(nir_err(path, format!("node `{name}`: tau {tau} s is not above the step {dt} s")));
        }
        Ok(1.0 - dt / tau)
    };
    let reset = match opts.reset {
        ImportReset::ToVReset => Reset::Zero,
        ImportReset::Subtract => Reset::Subtract,
    };
    let (p, scale) = match node.kind.as_str() {
        "LIF" => {
            let tau = get("tau", None)?;
            let mut p = NeuronParams::lif(factor(tau)? as f32);
            p.v_th = get("v_threshold", None)? as f32;
            p.v_reset = get("v_reset", Some(0.0))? as f32;
            p.v_leak = get("v_leak", Some(0.0))? as f32;
            (p, get("r", Some(1.0))? * dt / tau)
        }
        "CubaLIF" => {
            let (ts, tm) = (get("tau_syn", None)?, get("tau_mem", None)?);
            let mut p = NeuronParams::cuba_lif(factor(ts)? as f32, factor(tm)? as f32);
            p.v_th = get("v_threshold", None)? as f32;
            p.v_reset = get("v_reset", Some(0.0))? as f32;
            p.v_leak = get("v_leak", Some(0.0))? as f32;
            (p, get("r", Some(1.0))? * dt / tm * get("w_in", Some(1.0))? * dt / ts)
        }
        "IF" => {
            let mut p = NeuronParams::integrate_and_fire();
            p.v_th = get("v_threshold", None)? as f32;
            p.v_reset = get("v_reset", Some(0.0))? as f32;
            (p, get("r", Some(1.0))?)
        }
        "LI" => {
            let tau = get("tau", None)?;
            let mut p = NeuronParams::leaky_integrator(factor(tau)? as f32);
            p.v_leak = get("v_leak", Some(0.0))? as f32;
            (p, get("r", Some(1.0))? * dt / tau)
        }
        other => return Err(nir_err(path, format!("node `{name}`: `{other}` is not a neuron"))),
    };
    Ok((p.with_reset(reset), scale))
}

/// The linear op of a node, for an input of `shape`.
fn op(path: &Path, name: &str, node: &Node, shape: &[usize]) -> Result<Op> {
    let w = || {
        node.params.get("weight").ok_or_else(|| nir_err(path, format!("node `{name}` ({}): no `weight`", node.kind)))
    };
    let n_in: usize = shape.iter().product();
    let chw = || -> Result<[usize; 3]> {
        match *shape {
            [c, h, w] => Ok([c, h, w]),
            _ => Err(nir_err(path, format!("node `{name}` ({}) needs a [C, H, W] input, gets {shape:?}", node.kind))),
        }
    };
    match node.kind.as_str() {
        "Affine" | "Linear" => {
            let w = w()?;
            if w.shape.len() != 2 || w.shape[1] != n_in {
                return Err(nir_err(path, format!("node `{name}`: weight {:?} does not take {n_in} inputs", w.shape)));
            }
            let bias = if node.kind == "Affine" { node.params.get("bias").map(Array::f32s) } else { None };
            if bias.as_ref().is_some_and(|b| b.len() != w.shape[0]) {
                return Err(nir_err(path, format!("node `{name}`: bias length differs from {} outputs", w.shape[0])));
            }
            Ok(Op::Dense { n_in, n_out: w.shape[0], weight: w.f32s(), bias })
        }
        "Conv2d" => {
            let w = w()?;
            let in_shape = chw()?;
            if w.shape.len() != 4 || w.shape[1] != in_shape[0] {
                return Err(nir_err(path, format!("node `{name}`: weight {:?} does not fit input {shape:?}", w.shape)));
            }
            if pair(path, name, node, "dilation", 1)? != [1, 1]
                || uniform(path, name, node, "groups", Some(1.0))? != 1.0
            {
                return Err(nir_err(path, format!("node `{name}` (Conv2d): dilation and groups are not supported")));
            }
            Ok(Op::Conv2d {
                in_shape,
                out_channels: w.shape[0],
                kernel: [w.shape[2], w.shape[3]],
                stride: pair(path, name, node, "stride", 1)?,
                padding: pair(path, name, node, "padding", 0)?,
                weight: w.f32s(),
                bias: node.params.get("bias").map(Array::f32s),
            })
        }
        "SumPool2d" | "AvgPool2d" => {
            if pair(path, name, node, "padding", 0)? != [0, 0] {
                return Err(nir_err(path, format!("node `{name}` ({}): padding is not supported", node.kind)));
            }
            let kernel = pair(path, name, node, "kernel_size", 1)?;
            Ok(Op::Pool {
                kind: if node.kind == "SumPool2d" { PoolKind::Sum } else { PoolKind::Avg },
                in_shape: chw()?,
                kernel,
                stride: pair(path, name, node, "stride", kernel[0])?,
            })
        }
        other => Err(nir_err(path, format!("node `{name}`: `{other}` is not supported by the engine"))),
    }
}

fn scale_op(op: &mut Op, s: f32) {
    if let Op::Dense { weight, bias, .. } | Op::Conv2d { weight, bias, .. } = op {
        weight.iter_mut().for_each(|w| *w *= s);
        if let Some(b) = bias {
            b.iter_mut().for_each(|v| *v *= s);
        }
    }
}

/// What an import gives: the network, and the names of the nodes behind each layer.
#[derive(Debug, Clone)]
pub struct Imported {
    pub network: Network,
    /// Per layer: (op node, neuron node if any).
    pub layer_nodes: Vec<(String, Option<String>)>,
}

/// Turns a graph into a network for the engine: a chain from `input` to `output`, each linear node
/// optionally followed by neurons with an optional recurrent loop.
pub fn import(path: &Path, g: &Graph, opts: &ImportOptions) -> Result<Imported> {
    let find = |kind: &str| g.nodes.iter().find(|(_, n)| n.kind == kind).map(|(k, _)| k.clone());
    let input = find("Input").ok_or_else(|| nir_err(path, "no Input node"))?;
    for (a, b) in &g.edges {
        for n in [a, b] {
            if !g.nodes.contains_key(n) {
                return Err(nir_err(path, format!("edge ({a}, {b}) names a node `{n}` the graph lacks")));
            }
        }
    }
    let succ = |n: &str| -> Vec<&String> { g.edges.iter().filter(|(a, _)| a == n).map(|(_, b)| b).collect() };
    let node = |n: &str| &g.nodes[n];
    let in_node = node(&input);
    let mut shape: Vec<usize> = in_node
        .params
        .get("shape")
        .or_else(|| in_node.params.get("input_type.input"))
        .map(|a| a.data.iter().map(|&v| v as usize).collect())
        .ok_or_else(|| nir_err(path, format!("Input node `{input}` has no shape")))?;
    let input_shape = shape.clone();
    let mut layers: Vec<Layer> = Vec::new();
    let mut layer_nodes = Vec::new();
    let mut visited = vec![input.clone()];
    let next_of = |n: &str, visited: &[String]| -> Result<Option<String>> {
        let fwd: Vec<&String> = succ(n).into_iter().filter(|s| !visited.contains(s)).collect();
        match fwd.as_slice() {
            [] => Ok(None),
            [one] => Ok(Some((*one).clone())),
            many => Err(nir_err(
                path,
                format!("node `{n}` branches to {many:?}; only chains (with recurrent loops) are supported"),
            )),
        }
    };
    let mut cur = next_of(&input, &visited)?;
    while let Some(name) = cur {
        visited.push(name.clone());
        let n = node(&name);
        match n.kind.as_str() {
            "Output" => break,
            "Flatten" => {
                let start = uniform(path, &name, n, "start_dim", Some(0.0))?;
                let end = uniform(path, &name, n, "end_dim", Some(-1.0))?;
                if !(start == 0.0 && (end == -1.0 || end as usize + 1 == shape.len())) {
                    return Err(nir_err(
                        path,
                        format!("node `{name}` (Flatten): only a flatten of the whole [C, H, W] tensor is supported"),
                    ));
                }
                shape = vec![shape.iter().product()];
                cur = next_of(&name, &visited)?;
            }
            k if is_neuron(k) => {
                return Err(nir_err(
                    path,
                    format!(
                        "node `{name}` ({k}) follows no linear node; the engine needs one before each neuron layer"
                    ),
                ));
            }
            _ => {
                let mut o = op(path, &name, n, &shape)?;
                let mut next = next_of(&name, &visited)?;
                let mut neurons = None;
                let mut recurrent = None;
                let mut recurrent_bias = None;
                let mut neuron_name = None;
                if let Some(nn) = next.clone().filter(|nn| is_neuron(&node(nn).kind)) {
                    visited.push(nn.clone());
                    let (p, scale) = neuron(path, &nn, node(&nn), opts)?;
                    let s = scale as f32;
                    if s != 1.0 {
                        scale_op(&mut o, s);
                    }
                    // a loop back into this neuron node through one linear node
                    for r in succ(&nn) {
                        if succ(r).iter().any(|b| **b == nn) {
                            let rn = node(r);
                            let n_out = o.n_out();
                            let Op::Dense { weight, bias, .. } = op(path, r, rn, &[n_out])? else {
                                return Err(nir_err(
                                    path,
                                    format!("node `{r}`: a recurrent connection must be Affine or Linear"),
                                ));
                            };
                            recurrent = Some(weight.iter().map(|w| w * s).collect::<Vec<f32>>());
                            recurrent_bias = bias.map(|b| b.iter().map(|v| v * s).collect());
                            visited.push(r.clone());
                        }
                    }
                    neurons = Some(p);
                    neuron_name = Some(nn.clone());
                    next = next_of(&nn, &visited)?;
                }
                shape = o.out_shape();
                layers.push(Layer { op: o, neurons, recurrent, recurrent_bias });
                layer_nodes.push((name.clone(), neuron_name));
                cur = next;
            }
        }
    }
    if let Some(unused) = g.nodes.keys().find(|k| !visited.contains(k)) {
        return Err(nir_err(
            path,
            format!("node `{unused}` ({}) is not on the chain from `{input}` to the output", g.nodes[unused].kind),
        ));
    }
    let network = Network::new(input_shape, layers).map_err(|e| nir_err(path, e.to_string()))?;
    Ok(Imported { network, layer_nodes })
}

/// How reset by subtraction is exported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SubtractExport {
    /// Refuse: the file would change the dynamics.
    #[default]
    Refuse,
    /// Write it (NIR resets to `v_reset`), accepting changed dynamics.
    AsReset,
}

/// How an exported graph writes each neuron's time constants and input scales: NIR's equations
/// leave the split between weights, `r` and `w_in` free, and each peer's importer reads only some
/// splits as trained (docs/nir.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Convention {
    /// NIR's equations at the model's own step, in the layout of snnTorch's exporter:
    /// `tau = dt / (1 - beta)`, `r = tau / dt`, `w_in = tau_syn / dt`, the weights as trained. Read
    /// as trained by any importer told the model's `dt` (ours, Norse's CubaLIF, NIR's reference).
    #[default]
    Nir,
    /// For snnTorch 1.0's `import_from_nir`, which assumes a step of 100 us: the same layout with
    /// the time constants of a 100 us step (`tau = 1e-4 / (1 - beta)`), so that it recovers the
    /// trained decays and unit input scales. The file's time runs one model step per 100 us:
    /// import it at `dt = 1e-4 s` and feed it one model step per 100 us.
    Snntorch,
    /// Unit input scales (`r = 1`, `w_in = 1`) with the factors `tau / dt` (and
    /// `tau_syn / dt`) folded into the weights and biases that feed each neuron layer: NIR's
    /// equations at the model's step, and what Norse 1.1 runs as trained (its LIF ignores `r`).
    Norse,
}

impl Convention {
    pub fn name(self) -> &'static str {
        match self {
            Convention::Nir => "nir",
            Convention::Snntorch => "snntorch",
            Convention::Norse => "norse",
        }
    }

    /// The step, in seconds, at which an importer reads a graph written at `dt_s` this way.
    pub fn import_dt_s(self, dt_s: f64) -> f64 {
        match self {
            Convention::Snntorch => SNNTORCH_DT_S,
            Convention::Nir | Convention::Norse => dt_s,
        }
    }
}

/// The step snnTorch 1.0's NIR importer and exporter assume (`dt = 1e-4` in `import_nir.py`).
pub const SNNTORCH_DT_S: f64 = 1e-4;

/// What an export writes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExportOptions {
    /// The model's step, in seconds.
    pub dt_s: f64,
    pub subtract: SubtractExport,
    pub convention: Convention,
}

impl ExportOptions {
    /// NIR's own convention at step `dt_s`, refusing reset by subtraction.
    pub fn new(dt_s: f64) -> ExportOptions {
        ExportOptions { dt_s, subtract: SubtractExport::Refuse, convention: Convention::Nir }
    }
}

/// A neuron layer's NIR node: its type, its parameters and the factor folded into the weights
/// that feed it.
fn neuron_node(
    k: usize,
    np: &NeuronParams,
    shape: &[usize],
    o: &ExportOptions,
) -> Result<(&'static str, BTreeMap<String, Array>, f64)> {
    let p = Path::new("<export>");
    let dt = o.convention.import_dt_s(o.dt_s);
    let unit = o.convention == Convention::Norse;
    let tau_of = |f: f32| -> Result<f64> {
        if f >= 1.0 || f <= 0.0 {
            return Err(nir_err(p, format!("layer {k}: decay {f} has no finite time constant")));
        }
        Ok(dt / (1.0 - f as f64))
    };
    let full = |v: f64| Array::full(shape, v);
    Ok(match np.kind {
        NeuronKind::Lif | NeuronKind::Li => {
            let tau = tau_of(np.beta)?;
            let (r, fold) = if unit { (1.0, tau / dt) } else { (tau / dt, 1.0) };
            let mut m = BTreeMap::from([
                ("tau".into(), full(tau)),
                ("r".into(), full(r)),
                ("v_leak".into(), full(np.v_leak as f64)),
            ]);
            if np.kind == NeuronKind::Lif {
                m.insert("v_threshold".into(), full(np.v_th as f64));
                m.insert("v_reset".into(), full(np.v_reset as f64));
            }
            (if np.kind == NeuronKind::Lif { "LIF" } else { "LI" }, m, fold)
        }
        NeuronKind::CubaLif => {
            let (ts, tm) = (tau_of(np.alpha)?, tau_of(np.beta)?);
            let (r, w_in, fold) = if unit { (1.0, 1.0, (tm / dt) * (ts / dt)) } else { (tm / dt, ts / dt, 1.0) };
            let m = BTreeMap::from([
                ("tau_syn".into(), full(ts)),
                ("tau_mem".into(), full(tm)),
                ("r".into(), full(r)),
                ("w_in".into(), full(w_in)),
                ("v_leak".into(), full(np.v_leak as f64)),
                ("v_threshold".into(), full(np.v_th as f64)),
                ("v_reset".into(), full(np.v_reset as f64)),
            ]);
            ("CubaLIF", m, fold)
        }
        NeuronKind::If => {
            let m = BTreeMap::from([
                ("r".into(), full(1.0)),
                ("v_threshold".into(), full(np.v_th as f64)),
                ("v_reset".into(), full(np.v_reset as f64)),
            ]);
            ("IF", m, 1.0)
        }
    })
}

/// The graph of `net`, written as `opts` says.
pub fn export(net: &Network, opts: &ExportOptions) -> Result<Graph> {
    let mut g = Graph { version: NIR_VERSION.to_string(), ..Graph::default() };
    let p = Path::new("<export>");
    let arr = |shape: &[usize], data: &[f32], s: f64| Array {
        shape: shape.to_vec(),
        data: data.iter().map(|&v| if s == 1.0 { v as f64 } else { (v as f64 * s) as f32 as f64 }).collect(),
    };
    let ints = |v: &[usize]| Array { shape: vec![v.len()], data: v.iter().map(|&x| x as f64).collect() };
    g.nodes.insert(
        "input".into(),
        Node { kind: "Input".into(), params: BTreeMap::from([("shape".into(), ints(&net.input_shape))]) },
    );
    let mut prev = "input".to_string();
    let mut shape = net.input_shape.clone();
    for (k, l) in net.layers.iter().enumerate() {
        if let (Op::Dense { .. }, true) = (&l.op, shape.len() > 1) {
            let name = format!("layer{k}.flatten");
            let params = BTreeMap::from([
                ("start_dim".into(), Array::scalar(0.0)),
                ("end_dim".into(), Array::scalar(-1.0)),
                ("input_type".into(), ints(&shape)),
            ]);
            g.nodes.insert(name.clone(), Node { kind: "Flatten".into(), params });
            g.edges.push((prev, name.clone()));
            prev = name;
        }
        let out_shape = l.op.out_shape();
        let neurons = match &l.neurons {
            Some(np) => {
                if np.reset == Reset::Subtract && np.kind != NeuronKind::Li && opts.subtract == SubtractExport::Refuse {
                    return Err(nir_err(
                        p,
                        format!(
                            "layer {k} resets by subtraction, which NIR cannot encode (its neurons reset to v_reset); export with the reset written as v_reset to accept changed dynamics, or train with reset to zero"
                        ),
                    ));
                }
                Some(neuron_node(k, np, &out_shape, opts)?)
            }
            None => None,
        };
        let fold = neurons.as_ref().map_or(1.0, |n| n.2);
        let name = format!("layer{k}.op");
        let node = match &l.op {
            Op::Dense { n_in, n_out, weight, bias } => {
                let mut params = BTreeMap::from([("weight".into(), arr(&[*n_out, *n_in], weight, fold))]);
                match bias {
                    Some(b) => {
                        params.insert("bias".into(), arr(&[*n_out], b, fold));
                        Node { kind: "Affine".into(), params }
                    }
                    None => Node { kind: "Linear".into(), params },
                }
            }
            Op::Conv2d { in_shape, out_channels, kernel, stride, padding, weight, bias } => {
                let zero = vec![0.0; *out_channels];
                let params = BTreeMap::from([
                    ("weight".into(), arr(&[*out_channels, in_shape[0], kernel[0], kernel[1]], weight, fold)),
                    ("bias".into(), arr(&[*out_channels], bias.as_deref().unwrap_or(&zero), fold)),
                    ("stride".into(), ints(stride)),
                    ("padding".into(), ints(padding)),
                    ("dilation".into(), ints(&[1, 1])),
                    ("groups".into(), Array::scalar(1.0)),
                    ("input_shape".into(), ints(&[in_shape[1], in_shape[2]])),
                ]);
                Node { kind: "Conv2d".into(), params }
            }
            Op::Pool { kind, kernel, stride, .. } => {
                if fold != 1.0 {
                    return Err(nir_err(
                        p,
                        format!(
                            "layer {k}: neurons fed by pooling have no weights to fold their input scale into; export with the `nir` convention"
                        ),
                    ));
                }
                let params = BTreeMap::from([
                    ("kernel_size".into(), ints(kernel)),
                    ("stride".into(), ints(stride)),
                    ("padding".into(), ints(&[0, 0])),
                ]);
                Node { kind: if *kind == PoolKind::Sum { "SumPool2d" } else { "AvgPool2d" }.into(), params }
            }
        };
        g.nodes.insert(name.clone(), node);
        g.edges.push((prev, name.clone()));
        prev = name;
        shape = out_shape;
        if let Some((kind, params, fold)) = neurons {
            let name = format!("layer{k}.neurons");
            g.nodes.insert(name.clone(), Node { kind: kind.into(), params });
            g.edges.push((prev, name.clone()));
            if let Some(w) = &l.recurrent {
                let n = l.op.n_out();
                let rname = format!("layer{k}.w_rec");
                let mut params = BTreeMap::from([("weight".into(), arr(&[n, n], w, fold))]);
                let kind = match &l.recurrent_bias {
                    Some(b) => {
                        params.insert("bias".into(), arr(&[n], b, fold));
                        "Affine"
                    }
                    None => "Linear",
                };
                g.nodes.insert(rname.clone(), Node { kind: kind.into(), params });
                g.edges.push((name.clone(), rname.clone()));
                g.edges.push((rname, name.clone()));
            }
            prev = name;
        }
    }
    g.nodes.insert(
        "output".into(),
        Node { kind: "Output".into(), params: BTreeMap::from([("shape".into(), ints(&shape))]) },
    );
    g.edges.push((prev, "output".into()));
    Ok(g)
}

/// Chip target profiles: what each toolchain accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Target {
    Generic,
    Loihi2,
    Speck,
    Xylo,
    Spinnaker2,
}

impl Target {
    /// The chips, in table order.
    pub const CHIPS: [Target; 4] = [Target::Speck, Target::Xylo, Target::Loihi2, Target::Spinnaker2];

    pub fn name(self) -> &'static str {
        match self {
            Target::Generic => "generic",
            Target::Loihi2 => "Loihi 2",
            Target::Speck => "Speck",
            Target::Xylo => "Xylo",
            Target::Spinnaker2 => "SpiNNaker 2",
        }
    }
}

/// Speck's (DYNAP-CNN's) nine cores: kernel (weight) memory and neuron memory, in entries, as
/// Sinabs maps layers onto them (`sinabs.backend.dynapcnn.chips.dynapcnn`, `get_constraints`).
pub const SPECK_KERNEL_MEMORY: [u64; 9] =
    [16 << 10, 16 << 10, 16 << 10, 32 << 10, 32 << 10, 64 << 10, 64 << 10, 16 << 10, 16 << 10];
pub const SPECK_NEURON_MEMORY: [u64; 9] =
    [64 << 10, 64 << 10, 64 << 10, 32 << 10, 32 << 10, 16 << 10, 16 << 10, 16 << 10, 16 << 10];
/// Xylo (Xylo Audio v2, SYNS61201) as Rockpool's mapper and the chip's input interface take it.
pub const XYLO_MAX_INPUTS: usize = 16;
pub const XYLO_MAX_HIDDEN: usize = 1000;
pub const XYLO_MAX_OUTPUTS: usize = 8;

fn pow2_ceil_log2(n: usize) -> u64 {
    1u64 << (n.max(1) as f64).log2().ceil() as u32
}

/// One Speck core's needs: (kernel memory, neuron memory), Sinabs' `memory_summary`: kernel
/// `c_in * 2^(ceil log2(kh kw) + ceil log2 c_out)`, neurons `c_out * 2^(ceil log2 h + ceil log2 w)`.
fn speck_memory(c_in: usize, kernel: [usize; 2], c_out: usize, out_hw: [usize; 2]) -> (u64, u64) {
    let kernel_mem = c_in as u64 * pow2_ceil_log2(kernel[0] * kernel[1]) * pow2_ceil_log2(c_out);
    let neuron_mem = c_out as u64 * pow2_ceil_log2(out_hw[0]) * pow2_ceil_log2(out_hw[1]);
    (kernel_mem, neuron_mem)
}

/// Whether every layer's memory fits a core of its own.
fn speck_cores_fit(needs: &[(u64, u64)], used: &mut [bool; 9]) -> bool {
    let Some((&(k, n), rest)) = needs.split_first() else { return true };
    for c in 0..9 {
        if !used[c] && k <= SPECK_KERNEL_MEMORY[c] && n <= SPECK_NEURON_MEMORY[c] {
            used[c] = true;
            if speck_cores_fit(rest, used) {
                return true;
            }
            used[c] = false;
        }
    }
    false
}

/// Checks a network against a target's rules; the error names the layer (and its NIR node) and
/// the rule. The rules and their sources are in docs/nir.md.
pub fn check_target(net: &Network, target: Target) -> Result<()> {
    let p = Path::new("<target>");
    let fail = |k: usize, node: &str, rule: String| {
        Err(nir_err(p, format!("layer {k} (node `layer{k}.{node}`): {}: {rule}", target.name())))
    };
    let last = net.layers.len().saturating_sub(1);
    let mut shape = net.input_shape.clone();
    let mut hidden = 0usize;
    let mut speck_needs: Vec<(u64, u64)> = Vec::new();
    if target == Target::Speck
        && let [c, h, w] = shape[..]
        && (c > 2 || h > 128 || w > 128)
    {
        return fail(
            0,
            "op",
            format!("Speck's input is at most 2 x 128 x 128 (polarity, rows, columns), got {shape:?}"),
        );
    }
    for (k, l) in net.layers.iter().enumerate() {
        let kind = l.neurons.map(|n| n.kind);
        match target {
            Target::Generic => {}
            Target::Speck => {
                if let Some(n) = kind
                    && n != NeuronKind::If
                {
                    return fail(
                        k,
                        "neurons",
                        "Speck runs IF neurons only (no leak): convert LIF/CubaLIF to IF".into(),
                    );
                }
                if l.recurrent.is_some() {
                    return fail(k, "w_rec", "Speck has no recurrent connections".into());
                }
                if l.op.bias().is_some() {
                    return fail(
                        k,
                        "op",
                        "no biases (Speck applies a bias as a leak at its own clock, not per step)".into(),
                    );
                }
                match &l.op {
                    Op::Pool { kind: PoolKind::Avg, .. } => {
                        return fail(k, "op", "Speck pools by summing (SumPool2d), not averaging".into());
                    }
                    Op::Pool { kernel, stride, .. } => {
                        if kernel != stride || kernel[0] != kernel[1] || ![1, 2, 4].contains(&kernel[0]) {
                            return fail(
                                k,
                                "op",
                                format!(
                                    "a core pools by 1, 2 or 4, square, stride equal to the kernel; got kernel {kernel:?} stride {stride:?}"
                                ),
                            );
                        }
                        if k == 0
                            || net.layers[k - 1].neurons.is_none() && !matches!(net.layers[k - 1].op, Op::Pool { .. })
                        {
                            return fail(
                                k,
                                "op",
                                "pooling sits at a core's output: it must follow a spiking layer".into(),
                            );
                        }
                    }
                    Op::Conv2d { in_shape, out_channels, kernel, stride, .. } => {
                        if kernel[0] != kernel[1] || kernel[0] > 16 {
                            return fail(k, "op", format!("kernels are square and at most 16 x 16, got {kernel:?}"));
                        }
                        if stride.iter().any(|s| ![1, 2, 4, 8].contains(s)) {
                            return fail(k, "op", format!("strides are 1, 2, 4 or 8, got {stride:?}"));
                        }
                        let o = l.op.out_shape();
                        speck_needs.push(speck_memory(in_shape[0], *kernel, *out_channels, [o[1], o[2]]));
                    }
                    Op::Dense { n_out, .. } => {
                        // a dense layer is a convolution whose kernel covers its [C, H, W] input
                        let (c, h, w) = match shape[..] {
                            [c, h, w] => (c, h, w),
                            _ => (shape.iter().product(), 1, 1),
                        };
                        if h != w || h > 16 {
                            return fail(
                                k,
                                "op",
                                format!(
                                    "a dense layer runs as a convolution over its whole input, so its input's height and width must be equal and at most 16, got {shape:?}"
                                ),
                            );
                        }
                        speck_needs.push(speck_memory(c, [h, w], *n_out, [1, 1]));
                    }
                }
                if !matches!(l.op, Op::Pool { .. }) && l.neurons.is_none() {
                    return fail(k, "op", "every convolution or dense layer feeds IF neurons on its core".into());
                }
            }
            Target::Xylo => {
                if matches!(l.op, Op::Conv2d { .. } | Op::Pool { .. }) {
                    return fail(
                        k,
                        "op",
                        "Xylo has no convolution or pooling: dense (and recurrent) layers only".into(),
                    );
                }
                if let Some(n) = kind
                    && !matches!(n, NeuronKind::CubaLif | NeuronKind::Lif | NeuronKind::Li)
                {
                    return fail(k, "neurons", "Xylo runs (current-based) LIF neurons".into());
                }
                if k == 0 && net.n_inputs() > XYLO_MAX_INPUTS {
                    return fail(
                        0,
                        "op",
                        format!(
                            "Xylo takes at most {XYLO_MAX_INPUTS} input channels, the network has {}",
                            net.n_inputs()
                        ),
                    );
                }
                if k == last {
                    if l.op.n_out() > XYLO_MAX_OUTPUTS {
                        return fail(
                            k,
                            "op",
                            format!("Xylo has {XYLO_MAX_OUTPUTS} output neurons, the layer has {}", l.op.n_out()),
                        );
                    }
                    if l.recurrent.is_some() {
                        return fail(k, "w_rec", "Xylo's output neurons have no recurrent input".into());
                    }
                    if k == 0 {
                        return fail(
                            k,
                            "op",
                            "Xylo's inputs feed hidden neurons only: the network needs a hidden layer".into(),
                        );
                    }
                } else {
                    hidden += l.op.n_out();
                    if hidden > XYLO_MAX_HIDDEN {
                        return fail(
                            k,
                            "op",
                            format!(
                                "Xylo holds at most {XYLO_MAX_HIDDEN} hidden neurons in all, the layers up to this one have {hidden}"
                            ),
                        );
                    }
                }
            }
            Target::Loihi2 => {
                if matches!(l.op, Op::Pool { kind: PoolKind::Avg, .. }) {
                    return fail(k, "op", "Loihi 2 (lava-dl) pools by summing; average pooling is not mapped".into());
                }
            }
            Target::Spinnaker2 => {
                if matches!(l.op, Op::Conv2d { .. } | Op::Pool { .. }) {
                    return fail(
                        k,
                        "op",
                        "the SpiNNaker2 NIR mapping (py-spinnaker2) takes dense and recurrent layers".into(),
                    );
                }
                if kind == Some(NeuronKind::If) {
                    return fail(k, "neurons", "the SpiNNaker2 NIR mapping runs LIF and CubaLIF neurons".into());
                }
            }
        }
        shape = l.op.out_shape();
    }
    if target == Target::Speck {
        if speck_needs.len() > 9 {
            return fail(last, "op", format!("Speck has 9 cores, the network needs {}", speck_needs.len()));
        }
        if !speck_cores_fit(&speck_needs, &mut [false; 9]) {
            return fail(
                last,
                "op",
                format!(
                    "the layers' (kernel, neuron) memory {speck_needs:?} does not fit Speck's cores (kernel {SPECK_KERNEL_MEMORY:?}, neurons {SPECK_NEURON_MEMORY:?})"
                ),
            );
        }
    }
    Ok(())
}

/// Most elements a dataset may declare (256 MiB of float64): a corrupt header claiming more is
/// refused before anything is allocated.
pub const MAX_DATASET_ELEMENTS: u64 = 32 << 20;

fn check_size(path: &Path, name: &str, shape: &[u64]) -> Result<()> {
    let n = shape.iter().try_fold(1u64, |a, &d| a.checked_mul(d));
    match n {
        Some(n) if n <= MAX_DATASET_ELEMENTS => Ok(()),
        _ => Err(nir_err(
            path,
            format!("`{name}` declares shape {shape:?}, more than the limit of {MAX_DATASET_ELEMENTS} elements"),
        )),
    }
}
