//! Model files: safetensors (a documented, versioned tensor container readable from Python and
//! Rust) whose header metadata records what is needed to use the tensors correctly:
//!
//! | key | value |
//! | --- | --- |
//! | `format` | `braille-model` |
//! | `format_version` | [`FORMAT_VERSION`] |
//! | `arch` | `snn` or `resnet` |
//! | `config` | the architecture (JSON; for an SNN a [`SnnConfig`]) |
//! | `preprocess` | how input is encoded (JSON, owned by the trainer) |
//! | `classes` | class names by label (JSON list) |
//! | `provenance` | how the model was trained (JSON, informative) |
//! | `operating_point` | optional: where a reader reads a segmentation network's output (JSON, owned by the reader, set by its calibration on validation data) |
//!
//! Loading checks all of them, every tensor's shape against the config, and that every value is
//! finite; a failure names the file and the key or tensor.

use crate::error::{Error, Result};
use crate::network::Network;
use crate::spec::{LayerWeights, NetworkSpec};
use safetensors::tensor::{Dtype, SafeTensors, TensorView};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::Path;

pub const FORMAT: &str = "braille-model";
/// Version 1: float32 little-endian tensors, the keys above.
pub const FORMAT_VERSION: u32 = 1;

/// The architecture family a file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Arch {
    Snn,
    Resnet,
}

impl std::fmt::Display for Arch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.name())
    }
}

impl Arch {
    pub fn name(self) -> &'static str {
        match self {
            Arch::Snn => "snn",
            Arch::Resnet => "resnet",
        }
    }
}

/// A named float tensor.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedTensor {
    pub name: String,
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

/// Everything a model file holds, before any architecture interprets it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelFile {
    pub arch: Arch,
    pub config: serde_json::Value,
    pub preprocess: serde_json::Value,
    pub classes: Vec<String>,
    pub provenance: serde_json::Value,
    /// Optional: how a reader reads the model's output (JSON owned by the reader).
    pub operating_point: Option<serde_json::Value>,
    pub tensors: Vec<NamedTensor>,
}

fn model_err(path: &Path, what: impl Into<String>) -> Error {
    Error::Model { path: path.to_path_buf(), what: what.into() }
}

/// Writes `bytes` to `path` through [`encoders::formats::AtomicFile`] (a temporary sibling, then a
/// rename); an existing file is kept unless `force`.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8], force: bool) -> Result<()> {
    use std::io::Write;
    let mut f = encoders::formats::AtomicFile::create(path, force)?;
    f.write_all(bytes).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    Ok(f.commit()?)
}

impl ModelFile {
    /// Writes the file atomically (a temporary sibling, then a rename); an existing file is kept
    /// unless `force`.
    pub fn write(&self, path: &Path, force: bool) -> Result<()> {
        let json = |v: &serde_json::Value| v.to_string();
        let mut meta = HashMap::from([
            ("format".to_string(), FORMAT.to_string()),
            ("format_version".to_string(), FORMAT_VERSION.to_string()),
            ("arch".to_string(), self.arch.name().to_string()),
            ("config".to_string(), json(&self.config)),
            ("preprocess".to_string(), json(&self.preprocess)),
            ("classes".to_string(), serde_json::to_string(&self.classes).expect("strings serialise")),
            ("provenance".to_string(), json(&self.provenance)),
        ]);
        if let Some(p) = &self.operating_point {
            meta.insert("operating_point".to_string(), json(p));
        }
        let bytes: Vec<(String, Vec<u8>, Vec<usize>)> = self
            .tensors
            .iter()
            .map(|t| (t.name.clone(), t.data.iter().flat_map(|v| v.to_le_bytes()).collect(), t.shape.clone()))
            .collect();
        let views = bytes
            .iter()
            .map(|(n, b, s)| TensorView::new(Dtype::F32, s.clone(), b).map(|v| (n.clone(), v)))
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|e| model_err(path, format!("tensor layout: {e}")))?;
        let out = safetensors::serialize(views, Some(meta))
            .map_err(|source| Error::Safetensors { path: path.to_path_buf(), source: Box::new(source) })?;
        write_atomic(path, &out, force)
    }

    /// Reads and checks a model file of architecture `arch`.
    pub fn read(path: &Path, arch: Arch) -> Result<ModelFile> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        Self::parse(path, &bytes, arch)
    }

    /// The architecture a model file's header names (the format and its version checked).
    pub fn arch_of(path: &Path, bytes: &[u8]) -> Result<Arch> {
        let meta = Self::header(path, bytes)?;
        let found = &meta["arch"];
        [Arch::Snn, Arch::Resnet]
            .into_iter()
            .find(|a| a.name() == found)
            .ok_or_else(|| model_err(path, format!("header `arch` is `{found}`, not a known architecture")))
    }

    /// The header's metadata, its format, version and architecture checked present.
    fn header(path: &Path, bytes: &[u8]) -> Result<HashMap<String, String>> {
        let (_, metadata) = SafeTensors::read_metadata(bytes)
            .map_err(|e| model_err(path, format!("not a safetensors model file: {e}")))?;
        let meta = metadata.metadata().clone().unwrap_or_default();
        for key in ["format", "format_version", "arch"] {
            if !meta.contains_key(key) {
                return Err(model_err(path, format!("header key `{key}` is missing (not a {FORMAT} file?)")));
            }
        }
        if meta["format"] != FORMAT {
            return Err(model_err(path, format!("header `format` is `{}`, not `{FORMAT}`", meta["format"])));
        }
        let version = &meta["format_version"];
        if version.parse::<u32>().ok() != Some(FORMAT_VERSION) {
            return Err(model_err(
                path,
                format!("format version {version}; this build reads version {FORMAT_VERSION}"),
            ));
        }
        Ok(meta)
    }

    /// [`ModelFile::read`] on bytes already in memory; `path` names them in errors.
    pub fn parse(path: &Path, bytes: &[u8], arch: Arch) -> Result<ModelFile> {
        let meta = Self::header(path, bytes)?;
        let get = |key: &str| {
            meta.get(key)
                .ok_or_else(|| model_err(path, format!("header key `{key}` is missing (not a {FORMAT} file?)")))
        };
        let found = get("arch")?;
        if found != arch.name() {
            return Err(model_err(path, format!("holds a `{found}` model, `{}` was asked for", arch.name())));
        }
        let json = |key: &str| -> Result<serde_json::Value> {
            serde_json::from_str(get(key)?).map_err(|e| model_err(path, format!("header `{key}`: {e}")))
        };
        let classes: Vec<String> =
            serde_json::from_value(json("classes")?).map_err(|e| model_err(path, format!("header `classes`: {e}")))?;
        let st = SafeTensors::deserialize(bytes)
            .map_err(|source| Error::Safetensors { path: path.to_path_buf(), source: Box::new(source) })?;
        let mut tensors = Vec::new();
        let mut names: Vec<String> = st.names().into_iter().map(str::to_string).collect();
        names.sort();
        for name in names {
            let view = st.tensor(&name).map_err(|e| model_err(path, format!("tensor `{name}`: {e}")))?;
            if view.dtype() != Dtype::F32 {
                return Err(model_err(path, format!("tensor `{name}` is {:?}, version 1 stores F32", view.dtype())));
            }
            let data: Vec<f32> =
                view.data().chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
            if let Some(i) = data.iter().position(|v| !v.is_finite()) {
                return Err(model_err(path, format!("tensor `{name}` value {i} is {}", data[i])));
            }
            tensors.push(NamedTensor { name, shape: view.shape().to_vec(), data });
        }
        Ok(ModelFile {
            arch,
            config: json("config")?,
            preprocess: json("preprocess")?,
            classes,
            provenance: meta.get("provenance").and_then(|p| serde_json::from_str(p).ok()).unwrap_or_default(),
            operating_point: match meta.get("operating_point") {
                Some(_) => Some(json("operating_point")?),
                None => None,
            },
            tensors,
        })
    }

    /// Takes the tensor `name`, checking its shape.
    pub fn take(&mut self, path: &Path, name: &str, shape: &[usize]) -> Result<Vec<f32>> {
        let i = self
            .tensors
            .iter()
            .position(|t| t.name == name)
            .ok_or_else(|| model_err(path, format!("tensor `{name}` is missing")))?;
        let t = self.tensors.swap_remove(i);
        if t.shape != shape {
            return Err(model_err(
                path,
                format!("tensor `{name}` has shape {:?}, the config needs {shape:?}", t.shape),
            ));
        }
        Ok(t.data)
    }

    /// Fails if tensors the config did not ask for are left.
    pub fn finish(&self, path: &Path) -> Result<()> {
        match self.tensors.first() {
            Some(t) => Err(model_err(path, format!("tensor `{}` is not part of the config", t.name))),
            None => Ok(()),
        }
    }
}

/// How an SNN's outputs become a class.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Readout {
    /// The output neuron that spiked most (spiking output layer).
    SpikeCount,
    /// The output leaky integrator whose membrane rose highest.
    MaxMembrane,
}

impl Readout {
    /// The readout a network's output layer implies when nothing else says (a NIR graph): the
    /// highest membrane of a leaky-integrator layer, else spike counts.
    pub fn implied_by(net: &Network) -> Readout {
        match net.layers.last().and_then(|l| l.neurons).map(|p| p.kind) {
            Some(crate::neuron::NeuronKind::Li) => Readout::MaxMembrane,
            _ => Readout::SpikeCount,
        }
    }
}

/// An SNN's configuration as a model file records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SnnConfig {
    pub network: NetworkSpec,
    /// The step the network was trained at.
    pub dt_us: i64,
    pub readout: Readout,
}

/// A trained SNN: what the engine runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SnnModel {
    pub config: SnnConfig,
    pub network: Network,
    pub preprocess: serde_json::Value,
    pub classes: Vec<String>,
    pub provenance: serde_json::Value,
    /// Where a reader reads the output of a segmentation network (JSON owned by the reader);
    /// `None` for other models, and for a segmentation network never calibrated.
    pub operating_point: Option<serde_json::Value>,
}

impl SnnModel {
    pub fn save(&self, path: &Path, force: bool) -> Result<()> {
        let shapes = self.config.network.shapes()?;
        let mut tensors = Vec::new();
        for (k, (s, w)) in shapes.iter().zip(self.network.weights()).enumerate() {
            let mut put = |name: &str, shape: &Vec<usize>, data: Option<Vec<f32>>| {
                if let Some(data) = data {
                    tensors.push(NamedTensor { name: format!("layers.{k}.{name}"), shape: shape.clone(), data });
                }
            };
            put("weight", &s.weight, (!s.weight.is_empty()).then_some(w.weight));
            put("bias", &s.bias, w.bias);
            put("recurrent", &s.recurrent, w.recurrent);
            put("recurrent_bias", &s.recurrent_bias, w.recurrent_bias);
        }
        ModelFile {
            arch: Arch::Snn,
            config: serde_json::to_value(&self.config).expect("configs serialise"),
            preprocess: self.preprocess.clone(),
            classes: self.classes.clone(),
            provenance: self.provenance.clone(),
            operating_point: self.operating_point.clone(),
            tensors,
        }
        .write(path, force)
    }

    pub fn load(path: &Path) -> Result<SnnModel> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        Self::parse(path, &bytes)
    }

    /// [`SnnModel::load`] on bytes in memory; `path` names them in errors.
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<SnnModel> {
        let mut file = ModelFile::parse(path, bytes, Arch::Snn)?;
        let config: SnnConfig = serde_json::from_value(file.config.clone())
            .map_err(|e| model_err(path, format!("header `config`: {e}")))?;
        if config.dt_us <= 0 {
            return Err(model_err(path, format!("header `config`: dt_us {} is not positive", config.dt_us)));
        }
        let shapes = config.network.shapes().map_err(|e| model_err(path, format!("header `config`: {e}")))?;
        let mut weights = Vec::with_capacity(shapes.len());
        for (k, s) in shapes.iter().enumerate() {
            let mut take = |name: &str, shape: &Vec<usize>| -> Result<Option<Vec<f32>>> {
                if shape.is_empty() {
                    Ok(None)
                } else {
                    file.take(path, &format!("layers.{k}.{name}"), shape).map(Some)
                }
            };
            weights.push(LayerWeights {
                weight: take("weight", &s.weight)?.unwrap_or_default(),
                bias: take("bias", &s.bias)?,
                recurrent: take("recurrent", &s.recurrent)?,
                recurrent_bias: take("recurrent_bias", &s.recurrent_bias)?,
            });
        }
        file.finish(path)?;
        let network = config.network.build(weights).map_err(|e| model_err(path, e.to_string()))?;
        if config.readout == Readout::MaxMembrane
            && network.layers.last().and_then(|l| l.neurons).map(|p| p.kind) != Some(crate::neuron::NeuronKind::Li)
        {
            return Err(model_err(
                path,
                "header `config`: a max-membrane readout needs a leaky-integrator output layer",
            ));
        }
        if network.n_outputs() != file.classes.len() {
            return Err(model_err(path, format!("{} outputs for {} classes", network.n_outputs(), file.classes.len())));
        }
        Ok(SnnModel {
            config,
            network,
            preprocess: file.preprocess,
            classes: file.classes,
            provenance: file.provenance,
            operating_point: file.operating_point,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::{Layer, Op};
    use crate::neuron::NeuronParams;

    fn model() -> SnnModel {
        let net = Network::new(
            vec![3],
            vec![
                Layer {
                    op: Op::Dense { n_in: 3, n_out: 4, weight: (0..12).map(|i| i as f32 / 10.0).collect(), bias: None },
                    neurons: Some(NeuronParams::cuba_lif(0.5, 0.9)),
                    recurrent: Some(vec![0.25; 16]),
                    recurrent_bias: Some(vec![0.5, 0.0, -0.1, 0.2]),
                },
                Layer {
                    op: Op::Dense { n_in: 4, n_out: 2, weight: vec![0.5; 8], bias: Some(vec![0.0, 0.1]) },
                    neurons: Some(NeuronParams::leaky_integrator(0.95)),
                    recurrent: None,
                    recurrent_bias: None,
                },
            ],
        )
        .unwrap();
        SnnModel {
            config: SnnConfig { network: net.spec(), dt_us: 10_000, readout: Readout::MaxMembrane },
            network: net,
            preprocess: serde_json::json!({"sigma_delta": 2}),
            classes: vec!["a".into(), "b".into()],
            provenance: serde_json::json!({"seed": 1}),
            operating_point: Some(serde_json::json!({"present_threshold": 0.7})),
        }
    }

    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.safetensors");
        let m = model();
        m.save(&p, false).unwrap();
        assert_eq!(SnnModel::load(&p).unwrap(), m);
        // no overwrite without force
        assert!(m.save(&p, false).unwrap_err().to_string().contains("--force"));
        m.save(&p, true).unwrap();
    }

    /// Rewrites one header value of a saved model.
    fn with_meta(key: &str, value: &str) -> Vec<u8> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.safetensors");
        model().save(&p, false).unwrap();
        let mut f = ModelFile::read(&p, Arch::Snn).unwrap();
        let mut meta = HashMap::new();
        meta.insert(key.to_string(), value.to_string());
        match key {
            "config" => f.config = serde_json::from_str(value).unwrap(),
            "format_version" | "arch" | "format" => {}
            _ => unreachable!(),
        }
        f.write(&p, true).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        if matches!(key, "format_version" | "arch" | "format") {
            // patch the header text in place (same length keeps the offsets valid)
            let old = match key {
                "format_version" => format!("\"format_version\":\"{FORMAT_VERSION}\""),
                "arch" => "\"arch\":\"snn\"".to_string(),
                _ => format!("\"format\":\"{FORMAT}\""),
            };
            let new = format!("\"{key}\":\"{value}\"");
            assert_eq!(old.len(), new.len());
            let at = bytes.windows(old.len()).position(|w| w == old.as_bytes()).unwrap();
            let mut b = bytes.clone();
            b[at..at + old.len()].copy_from_slice(new.as_bytes());
            return b;
        }
        bytes
    }

    #[test]
    fn mismatches_are_named() {
        let p = Path::new("x.safetensors");
        let e = SnnModel::parse(p, &with_meta("format_version", "9")).unwrap_err().to_string();
        assert!(e.contains("x.safetensors") && e.contains("format version 9"), "{e}");
        let e = SnnModel::parse(p, &with_meta("arch", "cnn")).unwrap_err().to_string();
        assert!(e.contains("holds a `cnn` model"), "{e}");
        // a config whose shapes differ from the tensors: the tensor is named
        let mut c = serde_json::to_value(model().config).unwrap();
        c["network"]["layers"][1]["op"]["n_out"] = 3.into();
        let e = SnnModel::parse(p, &with_meta("config", &c.to_string())).unwrap_err().to_string();
        assert!(e.contains("tensor `layers.1.weight` has shape [2, 4], the config needs [3, 4]"), "{e}");
        let e = SnnModel::parse(p, b"\x08\x00\x00\x00\x00\x00\x00\x00{}      ").unwrap_err().to_string();
        assert!(e.contains("x.safetensors") && e.contains("`format` is missing"), "{e}");
        let e = SnnModel::parse(p, b"garbage").unwrap_err().to_string();
        assert!(e.contains("not a safetensors model file"), "{e}");
    }

    #[test]
    fn nan_weights_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.safetensors");
        let mut m = model();
        if let Op::Dense { weight, .. } = &mut m.network.layers[0].op {
            weight[5] = f32::NAN;
        }
        m.save(&p, false).unwrap();
        let e = SnnModel::load(&p).unwrap_err().to_string();
        assert!(e.contains("tensor `layers.0.weight` value 5 is NaN"), "{e}");
    }
}
