//! One loader for every model file: its header names the architecture ([`load`]). The CLI, the
//! benches, the reader and the experiments all load models here.

use crate::error::{Error, Result};
use crate::input::CharInput;
use learn::data::TactileEncoding;
use learn::resnet::ResnetConfig;
use snn::model_file::{Arch, ModelFile, NamedTensor, SnnModel};
use std::path::Path;

/// A trained ResNet and how its input is made. Its weights are kept as the model file's tensors
/// (burn's names): a reader folds them ([`learn::resnet::folded::FoldedResnet::from_tensors`]),
/// a trainer loads them into burn (`learn::resnet::from_tensors`, with learn's `train`).
pub struct ResnetModel {
    pub config: ResnetConfig,
    pub input: CharInput,
    pub tensors: Vec<NamedTensor>,
    pub classes: Vec<String>,
    pub provenance: serde_json::Value,
    /// Where a reader reads a segmentation network's output (JSON owned by the reader).
    pub operating_point: Option<serde_json::Value>,
}

fn bad(path: &Path, what: impl Into<String>) -> Error {
    Error::Model { path: path.to_path_buf(), what: what.into() }
}

impl ResnetModel {
    /// Writes the model file (atomically; an existing file is kept unless `force`).
    pub fn save(&self, path: &Path, force: bool) -> Result<()> {
        let json = |v: serde_json::Result<serde_json::Value>| v.map_err(|e| bad(path, e.to_string()));
        ModelFile {
            arch: Arch::Resnet,
            config: json(serde_json::to_value(&self.config))?,
            preprocess: json(serde_json::to_value(&self.input))?,
            classes: self.classes.clone(),
            provenance: self.provenance.clone(),
            operating_point: self.operating_point.clone(),
            tensors: self.tensors.clone(),
        }
        .write(path, force)?;
        Ok(())
    }

    /// A ResNet model file's bytes; `path` names them in errors.
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<ResnetModel> {
        let f = ModelFile::parse(path, bytes, Arch::Resnet)?;
        let config: ResnetConfig =
            serde_json::from_value(f.config.clone()).map_err(|e| bad(path, format!("header `config`: {e}")))?;
        let input: CharInput =
            serde_json::from_value(f.preprocess.clone()).map_err(|e| bad(path, format!("header `preprocess`: {e}")))?;
        if input.shape() != config.input {
            return Err(bad(
                path,
                format!("the preprocessing gives {:?}, the network takes {:?}", input.shape(), config.input),
            ));
        }
        if f.classes.len() != config.classes {
            return Err(bad(
                path,
                format!("{} class names for a network of {} outputs", f.classes.len(), config.classes),
            ));
        }
        // the tensors are checked against the configuration here, once, as folding them does
        learn::resnet::folded::FoldedResnet::from_tensors(&config, &f.tensors).map_err(|e| bad(path, e.to_string()))?;
        Ok(ResnetModel {
            config,
            input,
            tensors: f.tensors,
            classes: f.classes,
            provenance: f.provenance,
            operating_point: f.operating_point,
        })
    }
}

/// What a model file's `preprocess` header says its input is, parsed once where the model is
/// loaded: character windows of the labeler (the readers' models), a tactile dataset's encoding
/// (models trained on a dataset folder), or nothing recorded (a NIR twin's header, a bare
/// network).
#[derive(Debug, Clone, PartialEq)]
pub enum Preprocessing {
    CharWindows(CharInput),
    Tactile(TactileEncoding),
    None,
}

impl Preprocessing {
    /// The kind of a `preprocess` header by the key only its kind has (`labeler` for character
    /// windows, `channels` for a tactile encoding); a header of neither kind, or one of a kind
    /// that does not parse, is an error naming the file and the key.
    pub fn of_header(value: &serde_json::Value, path: &Path) -> Result<Preprocessing> {
        let header = |expected: &'static str, found: String| Error::Header {
            path: path.to_path_buf(),
            key: "preprocess",
            expected,
            found,
        };
        match value {
            serde_json::Value::Null => Ok(Preprocessing::None),
            serde_json::Value::Object(o) if o.is_empty() => Ok(Preprocessing::None),
            serde_json::Value::Object(o) if o.contains_key("labeler") => serde_json::from_value(value.clone())
                .map(Preprocessing::CharWindows)
                .map_err(|e| header("a character-window input", e.to_string())),
            serde_json::Value::Object(o) if o.contains_key("channels") => serde_json::from_value(value.clone())
                .map(Preprocessing::Tactile)
                .map_err(|e| header("a tactile encoding", e.to_string())),
            other => Err(header(
                "a character-window input (with `labeler`) or a tactile encoding (with `channels`)",
                other.to_string().chars().take(120).collect(),
            )),
        }
    }

    /// The kind's name, as errors and reports give it.
    pub fn kind(&self) -> &'static str {
        match self {
            Preprocessing::CharWindows(_) => "character windows",
            Preprocessing::Tactile(_) => "a tactile encoding",
            Preprocessing::None => "none recorded",
        }
    }
}

/// A loaded model of either architecture.
#[allow(clippy::large_enum_variant)] // a handful per process
pub enum Model {
    Resnet(ResnetModel),
    /// An SNN: on character windows, or on a tactile dataset's encoding (its `preprocess` says).
    Snn(SnnModel),
}

/// Loads a model file of any architecture, by what its header names.
pub fn load(path: &Path) -> Result<Model> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    Ok(match ModelFile::arch_of(path, &bytes)? {
        Arch::Resnet => Model::Resnet(ResnetModel::parse(path, &bytes)?),
        Arch::Snn => Model::Snn(SnnModel::parse(path, &bytes)?),
    })
}

/// Loads a model file that must hold an SNN.
pub fn load_snn(path: &Path) -> Result<SnnModel> {
    match load(path)? {
        Model::Snn(m) => Ok(m),
        Model::Resnet(_) => Err(bad(path, "holds a `resnet` model, an SNN was asked for")),
    }
}

impl Model {
    pub fn arch(&self) -> Arch {
        match self {
            Model::Resnet(_) => Arch::Resnet,
            Model::Snn(_) => Arch::Snn,
        }
    }

    pub fn classes(&self) -> &[String] {
        match self {
            Model::Resnet(m) => &m.classes,
            Model::Snn(m) => &m.classes,
        }
    }

    /// The reader's operating point its file records (a calibrated segmentation network).
    pub fn operating_point(&self) -> Option<&serde_json::Value> {
        match self {
            Model::Resnet(m) => m.operating_point.as_ref(),
            Model::Snn(m) => m.operating_point.as_ref(),
        }
    }

    /// Sets the operating point (`braille calibrate-reader --write`).
    pub fn set_operating_point(&mut self, point: Option<serde_json::Value>) {
        match self {
            Model::Resnet(m) => m.operating_point = point,
            Model::Snn(m) => m.operating_point = point,
        }
    }

    /// Writes the model file (atomically; an existing file is kept unless `force`).
    pub fn save(&self, path: &Path, force: bool) -> Result<()> {
        match self {
            Model::Resnet(m) => m.save(path, force),
            Model::Snn(m) => Ok(m.save(path, force)?),
        }
    }

    /// Reads the model's character windows centred in `band` (`None`: in its crop's rows) from
    /// now on, its weights unchanged ([`CharInput::band`]; `braille set-band`). The provenance
    /// records the change beside how the weights were trained (`input_changes`). `path` names
    /// the file in errors.
    pub fn set_band(&mut self, band: Option<std::ops::Range<usize>>, path: &Path) -> Result<()> {
        let mut input = self.char_input(path)?;
        let before = input.band.clone();
        input.band = band.clone();
        input.check_band().map_err(|e| bad(path, e.to_string()))?;
        let provenance = match self {
            Model::Resnet(m) => {
                m.input = input;
                &mut m.provenance
            }
            Model::Snn(m) => {
                m.preprocess = serde_json::to_value(&input).map_err(|e| bad(path, e.to_string()))?;
                &mut m.provenance
            }
        };
        let change = serde_json::json!({
            "band_rows": band.map(|b| [b.start, b.end]),
            "before": before.map(|b| [b.start, b.end]),
            "weights": "unchanged: trained on windows made as `before` says",
        });
        if let Some(o) = provenance.as_object_mut() {
            match o.get_mut("input_changes").and_then(|v| v.as_array_mut()) {
                Some(list) => list.push(change),
                None => {
                    o.insert("input_changes".into(), serde_json::json!([change]));
                }
            }
        }
        Ok(())
    }

    pub fn provenance(&self) -> &serde_json::Value {
        match self {
            Model::Resnet(m) => &m.provenance,
            Model::Snn(m) => &m.provenance,
        }
    }

    /// How the model's character windows are made; an error for an SNN of a tactile dataset.
    /// `path` names the file in errors.
    pub fn char_input(&self, path: &Path) -> Result<CharInput> {
        match self {
            Model::Resnet(m) => Ok(m.input.clone()),
            Model::Snn(m) => {
                let input = match Preprocessing::of_header(&m.preprocess, path)? {
                    Preprocessing::CharWindows(input) => input,
                    other => {
                        return Err(Error::Header {
                            path: path.to_path_buf(),
                            key: "preprocess",
                            expected: "a character-window input",
                            found: format!("{} (a model for `eval --data`?)", other.kind()),
                        });
                    }
                };
                let n = 2 * input.shape()[1] * input.shape()[2];
                if m.network.n_inputs() != n {
                    return Err(bad(
                        path,
                        format!("the preprocessing gives {n} inputs, the network takes {}", m.network.n_inputs()),
                    ));
                }
                Ok(input)
            }
        }
    }
}
