//! The character classifiers on SIMULATED windows: scoring a model of either architecture on a
//! set of windows (`braille eval chars`, Table I) and the ResNet's training protocol
//! (`braille train --arch resnet`).

use crate::Progress;
use crate::datasets::{CharSetSpec, Task, build, snn_set, training_windows};
use crate::error::{Error, Result};
use crate::scoring::Confusion;
use crate::tactile::{async_capable, snn_accuracy};
use learn::resnet::{ImageSet, ResnetConfig};
use learn::snn::{SnnParams, SnnTwin};
use pipeline::augment::{AugmentConfig, Preprocess};
use pipeline::input::{CharInput, LITE_COLS, LITE_ROWS};
use pipeline::labeling::LabelerConfig;
use pipeline::models::{Model, ResnetModel};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use snn::engine::Mode;
use snn::model_file::Arch;
use snn::neuron::Surrogate;
use std::path::{Path, PathBuf};

/// A character classifier of either architecture, with how its input is made.
pub struct CharModel {
    pub model: Model,
    pub input: CharInput,
}

/// The shipped character classifier of each architecture (paper protocol).
pub fn default_path(arch: Arch) -> PathBuf {
    match arch {
        Arch::Resnet => PathBuf::from("models/resnet-lite-normaug.safetensors"),
        Arch::Snn => PathBuf::from("models/snn-chars.safetensors"),
    }
}

/// How a classifier did on a set of windows.
#[derive(Debug, Clone, Serialize)]
pub struct Score {
    pub n: usize,
    pub accuracy: f64,
    pub macro_f1: f64,
    /// Cross-entropy of the network's outputs (the SNN's: of its time-stepped twin, which the
    /// stepped engine reproduces spike for spike).
    pub loss: f64,
    /// `[truth][predicted]`.
    pub confusion: Vec<Vec<u32>>,
    /// SNN only: the event-driven engine's work per window (stepped mode), and its accuracy in
    /// async mode where the network allows it (LIF/IF layers without bias or recurrence).
    pub synops_per_sample: Option<f64>,
    pub spikes_per_sample: Option<f64>,
    pub input_events_per_sample: Option<f64>,
    pub accuracy_async: Option<f64>,
}

impl CharModel {
    /// A model file of either architecture (its header says which) that reads character windows.
    pub fn load(path: &Path) -> Result<CharModel> {
        let model = pipeline::models::load(path)?;
        let input = model.char_input(path)?;
        Ok(CharModel { model, input })
    }

    pub fn arch(&self) -> Arch {
        self.model.arch()
    }

    /// ResNet: multiply-accumulates per window.
    pub fn macs(&self) -> Option<u64> {
        match &self.model {
            Model::Resnet(r) => Some(r.config.macs()),
            Model::Snn(_) => None,
        }
    }

    /// Scores the windows of `raw` (crops as [`build`] makes them for this model).
    pub fn score(&self, raw: &ImageSet) -> Result<Score> {
        match &self.model {
            Model::Resnet(m) => {
                let set = ImageSet {
                    shape: raw.shape,
                    data: raw.data.par_iter().map(|d| m.input.prepare(d, None)).collect(),
                    labels: raw.labels.clone(),
                };
                let (loss, accuracy, preds) = learn::resnet::evaluate(&m.model, &set, 32);
                let confusion = Confusion::from_pairs(26, set.labels.iter().copied().zip(preds));
                Ok(Score {
                    n: set.len(),
                    accuracy,
                    macro_f1: confusion.macro_f1(),
                    loss,
                    confusion: confusion.counts,
                    synops_per_sample: None,
                    spikes_per_sample: None,
                    input_events_per_sample: None,
                    accuracy_async: None,
                })
            }
            Model::Snn(model) => {
                let set =
                    snn_set(&self.input, raw, &(0..raw.len()).collect::<Vec<_>>(), model.config.dt_us, Task::Chars);
                let stepped = snn_accuracy(&model.network, &model.config, &set, Mode::Stepped)?;
                let accuracy_async = if async_capable(&model.network, model.config.dt_us) {
                    Some(snn_accuracy(&model.network, &model.config, &set, Mode::Async)?.accuracy)
                } else {
                    None
                };
                let twin = SnnTwin::new(
                    model.config.network.clone(),
                    Surrogate::FastSigmoid { slope: 1.0 },
                    model.config.readout,
                )?;
                let params = SnnParams::from_weights(
                    &model.config.network,
                    &model.network.weights(),
                    &burn::tensor::Device::flex(),
                )?;
                let (loss, _, _) = learn::train::evaluate(&twin, &params, &set, 64);
                Ok(Score {
                    n: stepped.n,
                    accuracy: stepped.accuracy,
                    macro_f1: crate::scoring::macro_f1(&stepped.confusion),
                    loss,
                    confusion: stepped.confusion,
                    synops_per_sample: Some(stepped.synops_per_sample),
                    spikes_per_sample: Some(stepped.spikes_per_sample),
                    input_events_per_sample: Some(stepped.input_events_per_sample),
                    accuracy_async,
                })
            }
        }
    }
}

/// A classifier scored on fresh SIMULATED scans (`braille eval chars`).
#[derive(Debug, Clone, Serialize)]
pub struct CharEval {
    pub data: &'static str,
    pub arch: Arch,
    pub model: String,
    pub board: String,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub scans: usize,
    pub skipped_scans: usize,
    /// Characters printed on every scan, and the share read right of them (the characters of
    /// scans the labeler miscounted count as errors); `accuracy` is over the windows found.
    pub printed: usize,
    pub accuracy_all: f64,
    #[serde(flatten)]
    pub score: Score,
}

/// Scores the model at `path` on the windows of `spec`.
pub fn eval(path: &Path, spec: &CharSetSpec, progress: &dyn Progress) -> Result<CharEval> {
    let m = CharModel::load(path)?;
    let (raw, w) = build(spec, &m.input, progress)?;
    let score = m.score(&raw)?;
    let right = crate::reports::chars::right(&score);
    Ok(CharEval {
        data: "simulated (virtual Evetac)",
        arch: m.arch(),
        model: path.display().to_string(),
        board: spec.boards.iter().map(|b| b.name()).collect::<Vec<_>>().join(","),
        speed_mm_s: spec.speed_mm_s,
        depth_mm: spec.depth_mm,
        scans: w.scans,
        skipped_scans: w.skipped_scans,
        printed: w.printed,
        accuracy_all: w.accuracy_all(right),
        score,
    })
}

/// The ResNet's size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum ResnetPreset {
    /// The paper's ResNet-34 input: the whole 160x120 pooled frame.
    Paper,
    /// A narrow ResNet on the 64x80 crop around the character.
    Lite,
    /// The smallest: for the segmentation network, which runs on every frame.
    Tiny,
}

/// A pooling factor that divides the lite crop.
pub fn check_pool(pool: usize) -> Result<usize> {
    let (h, w) = (LITE_ROWS.len(), LITE_COLS.len());
    if pool == 0 || h % pool != 0 || w % pool != 0 {
        return Err(Error::Invalid(format!("--pool must divide the {h}x{w} crop, got {pool}")));
    }
    Ok(pool)
}

/// The ResNet's training protocol on SIMULATED windows.
#[derive(Debug, Clone, Serialize)]
pub struct ResnetTraining {
    pub preset: ResnetPreset,
    pub preprocess: Preprocess,
    pub task: Task,
    pub jitter_ms: f64,
    /// Segmentation: blank cells as background too ([`crate::datasets::blank_cell_starts`]).
    pub blank_cells: bool,
    pub pool: usize,
    pub trials: u64,
    pub word_rows: usize,
    /// The simulator's nuisances (training sensor builds beyond `clean`).
    pub realism: sim::Realism,
    pub train: learn::train::TrainConfig,
}

/// A trained ResNet with its per-epoch history.
pub struct TrainedResnet {
    pub model: ResnetModel,
    pub history: Vec<learn::train::EpochReport>,
    pub best_val_accuracy: f64,
    pub train_windows: usize,
    pub val_windows: usize,
    pub scans: usize,
    pub skipped_scans: usize,
}

/// Trains a ResNet on the training protocol's windows (SAB and UN at 8 mm/s, 1.5 mm, plus word
/// rows), whole scans held out for validation.
pub fn train_resnet(
    t: &ResnetTraining,
    observer: &mut dyn learn::train::Observer,
    progress: &dyn Progress,
) -> Result<TrainedResnet> {
    let labeler = LabelerConfig::default();
    let (rows, cols) = match t.preset {
        ResnetPreset::Lite | ResnetPreset::Tiny => (LITE_ROWS, LITE_COLS),
        ResnetPreset::Paper => (0..120, 20..100),
    };
    let pool = if t.preset == ResnetPreset::Paper { 1 } else { check_pool(t.pool)? };
    let input = CharInput { labeler, rows, cols, pool, preprocess: t.preprocess, augment: AugmentConfig::default() };
    let world = crate::datasets::World::train(t.realism);
    let tw = training_windows(
        t.trials,
        t.train.seed,
        t.word_rows,
        &input,
        t.task,
        t.jitter_ms,
        t.blank_cells,
        &world,
        progress,
    )?;
    // the windows move into the two sets (no copy: the training set is most of the memory)
    let mut all = tw.all;
    let mut pick = |idx: &[usize], prepared: bool| ImageSet {
        shape: all.shape,
        data: idx
            .iter()
            .map(|&i| {
                let img = std::mem::take(&mut all.data[i]);
                if prepared { input.prepare(&img, None) } else { img }
            })
            .collect(),
        labels: idx.iter().map(|&i| all.labels[i]).collect(),
    };
    let train_set = pick(&tw.train, false);
    let val = pick(&tw.val, true);
    let classes = t.task.classes();
    let config = match t.preset {
        ResnetPreset::Lite => ResnetConfig::lite(input.shape(), classes.len()),
        ResnetPreset::Paper => ResnetConfig::paper(input.shape(), classes.len()),
        ResnetPreset::Tiny => ResnetConfig::tiny(input.shape(), classes.len()),
    };
    let started = std::time::Instant::now();
    let augment = |img: &[f32], rng: &mut rand_chacha::ChaCha8Rng| input.prepare(img, Some(rng));
    let (model, history) = learn::resnet::train(&config, &train_set, &val, &t.train, &augment, observer);
    let best = history.iter().map(|h| h.val_accuracy).fold(f64::NAN, f64::max);
    let provenance = serde_json::json!({
        "data": "simulated (virtual Evetac): SAB and UN boards, 8 mm/s, 1.5 mm",
        "realism": t.realism,
        "sensor_builds": world.sensors,
        "task": t.task,
        "jitter_ms": t.jitter_ms,
        "blank_cells": t.blank_cells,
        "word_rows": t.word_rows,
        "scans": tw.scans,
        "train_windows": train_set.len(),
        "val_windows": val.len(),
        "train": t.train,
        "best_val_accuracy": best,
        "train_seconds": started.elapsed().as_secs_f64(),
        "peak_rss_mb": crate::peak_rss_mb(),
    });
    Ok(TrainedResnet {
        model: ResnetModel { config, input, model, classes, provenance, operating_point: None },
        history,
        best_val_accuracy: best,
        train_windows: train_set.len(),
        val_windows: val.len(),
        scans: tw.scans,
        skipped_scans: tw.skipped_scans,
    })
}
