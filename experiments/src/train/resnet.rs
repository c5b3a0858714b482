//! The ResNet character classifiers' and segmentation networks' training on SIMULATED windows
//! (`braille train --arch resnet`): the training protocol's windows (SAB and UN at 8 mm/s, 1.5 mm,
//! plus word rows) cut by the paper's labeler, whole scans held out for validation.

use crate::Progress;
use crate::error::{Error, Result};
use corpus::windows::{Task, training_windows};
use learn::resnet::{ImageSet, ResnetConfig};
use pipeline::augment::{AugmentConfig, Preprocess};
use pipeline::input::{CharInput, LITE_COLS, LITE_ROWS};
use pipeline::labeling::LabelerConfig;
use pipeline::models::ResnetModel;
use serde::{Deserialize, Serialize};

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
        return Err(Error::Setting {
            name: "pool",
            value: pool.to_string(),
            expected: "a factor of the 64x80 lite crop",
        });
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
    /// Segmentation: blank cells as background too ([`corpus::windows::blank_cell_starts`]).
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
    /// The training's world and word rows, as the summary names them.
    pub realism: sim::Realism,
    pub word_rows: usize,
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
    let world = corpus::world::World::train(t.realism);
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
        realism: t.realism,
        word_rows: t.word_rows,
        model: ResnetModel { config, input, model, classes, provenance, operating_point: None },
        history,
        best_val_accuracy: best,
        train_windows: train_set.len(),
        val_windows: val.len(),
        scans: tw.scans,
        skipped_scans: tw.skipped_scans,
    })
}

/// The summary `braille train --arch resnet` prints.
impl std::fmt::Display for TrainedResnet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "SIMULATED training windows ({} realism): SAB and UN at 8 mm/s, 1.5 mm, {} rows of random words: {} scans ({} skipped: window count off), {} training and {} validation windows of {:?}",
            self.realism,
            self.word_rows,
            self.scans,
            self.skipped_scans,
            self.train_windows,
            self.val_windows,
            self.model.input.shape()
        )?;
        writeln!(f, "best validation accuracy {:.2}% (SIMULATED)", 100.0 * self.best_val_accuracy)
    }
}
