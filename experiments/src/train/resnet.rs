//! The ResNet character classifiers' and segmentation networks' training on SIMULATED windows
//! (`braille train --arch resnet`): the training protocol's windows (SAB and UN at 8 mm/s, 1.5 mm,
//! plus word rows) cut by the paper's labeler, whole scans held out for validation.

use crate::Progress;
use crate::error::{Error, Result};
use corpus::windows::{Task, training_windows};
use learn::resnet::{ImageSet, ResnetConfig};
use pipeline::input::{CharInput, LITE_COLS, LITE_ROWS};
use pipeline::labeling::LabelerConfig;
use pipeline::models::ResnetModel;
use pipeline::preprocess::{AugmentConfig, Preprocess};
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

/// The crop's pooled rows: `crop_rows` (first, last plus one) or the lite crop's
/// ([`LITE_ROWS`]), checked against the labeler's 120 rows.
pub fn crop_rows(crop_rows: Option<[usize; 2]>) -> Result<std::ops::Range<usize>> {
    match crop_rows {
        None => Ok(LITE_ROWS),
        Some([first, end]) if first < end && end <= 120 => Ok(first..end),
        Some([first, end]) => Err(Error::Setting {
            name: "crop_rows",
            value: format!("{first},{end}"),
            expected: "two pooled rows, first below last, within 0..=120",
        }),
    }
}

/// A pooling factor that divides the crop (`rows` by the lite crop's 80 columns).
pub fn check_pool(pool: usize, rows: &std::ops::Range<usize>) -> Result<usize> {
    let (h, w) = (rows.len(), LITE_COLS.len());
    if pool == 0 || h % pool != 0 || w % pool != 0 {
        return Err(Error::Setting {
            name: "pool",
            value: pool.to_string(),
            expected: "a factor of the crop's rows and its 80 columns",
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
    /// Lite and tiny: the crop's pooled rows, first and last plus one (`None`: [`LITE_ROWS`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crop_rows: Option<[usize; 2]>,
    /// The pooled rows the vertical centring looks in, wider than the crop (`None`: the crop's;
    /// [`CharInput::band`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band_rows: Option<[usize; 2]>,
    pub trials: u64,
    pub word_rows: usize,
    /// Rows that hold every letter at every place this many times (0: none).
    pub letter_rows: usize,
    /// Passes of letter strings holding every ordered pair of letters (0: none).
    #[serde(skip_serializing_if = "crate::train::recipe::is_zero_count")]
    pub pair_rows: usize,
    /// Training scans over speeds, depths and nuisance levels (`None`: 8 mm/s, 1.5 mm).
    pub sweep: Option<corpus::windows::Sweep>,
    /// A background-activity filter before windowing, recorded in the model's input
    /// (`SnnRecipe::denoise`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoise: Option<encoders::denoise::NoiseFilterSettings>,
    /// A cell reader's boards in this code in place of the letters' (`TrainingScans::cells`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cells: Option<pipeline::code::BrailleCode>,
    /// The simulator's nuisances (training sensor builds beyond `clean`).
    pub realism: sim::Realism,
    pub train: learn::train::TrainConfig,
}

impl ResnetTraining {
    /// The simulated training scans it asks for.
    pub fn scans(&self) -> corpus::windows::TrainingScans {
        corpus::windows::TrainingScans {
            trials: self.trials,
            seed: self.train.seed,
            word_rows: self.word_rows,
            letter_rows: self.letter_rows,
            pair_rows: self.pair_rows,
            sweep: self.sweep.clone(),
            cells: self.cells,
        }
    }
}

/// A trained ResNet with its per-epoch history.
pub struct TrainedResnet {
    pub model: ResnetModel,
    /// Where the windows came from, as the summary names it.
    pub data: String,
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
/// rows), whole scans held out for validation; or, with `recordings`, on a lab's recorded scans
/// (its `train` scans, its `val` scans for checkpoints). With `init`, training starts from that
/// model's weights (fine-tuning: the same preset, input and classes).
pub fn train_resnet(
    t: &ResnetTraining,
    recordings: Option<&corpus::recordings::Recordings>,
    init: Option<&std::path::Path>,
    observer: &mut dyn learn::train::Observer,
    progress: &dyn Progress,
) -> Result<TrainedResnet> {
    let labeler = LabelerConfig::default();
    let (rows, cols) = match (t.preset, t.crop_rows) {
        (ResnetPreset::Lite | ResnetPreset::Tiny, c) => (crop_rows(c)?, LITE_COLS),
        (ResnetPreset::Paper, None) => (0..120, 20..100),
        (ResnetPreset::Paper, Some([first, end])) => {
            return Err(Error::Setting {
                name: "crop_rows",
                value: format!("{first},{end}"),
                expected: "none for the paper preset (it sees the whole frame)",
            });
        }
    };
    let pool = if t.preset == ResnetPreset::Paper { 1 } else { check_pool(t.pool, &rows)? };
    // cells: shifts of at most 4% of the crop (about a third of a dot's pitch), so that a shift
    // never moves a dot to its neighbour's row (the letters' 10% would)
    let augment = match t.task {
        Task::Cells => AugmentConfig { translation: 0.04, ..AugmentConfig::default() },
        _ => AugmentConfig::default(),
    };
    let band = t.band_rows.map(|[first, end]| first..end);
    let input = CharInput { labeler, rows, cols, pool, preprocess: t.preprocess, augment, band, denoise: t.denoise };
    input.check_band()?;
    let world = corpus::world::World::train(t.realism);
    let tw = match recordings {
        Some(rec) => {
            corpus::windows::recorded_training_windows(rec, &input, t.task, t.jitter_ms, t.blank_cells, progress)?
        }
        None => training_windows(&t.scans(), &input, t.task, t.jitter_ms, t.blank_cells, &world, progress)?,
    };
    // the windows move into the two sets (no copy: the training set is most of the memory)
    let mut all = tw.all;
    let mut pick = |idx: &[usize], prepared: bool| ImageSet {
        shape: all.shape,
        data: idx
            .iter()
            .map(|&i| {
                let img = std::mem::take(&mut all.data[i]);
                if prepared { input.prepare(&img) } else { img }
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
    let data = match recordings {
        Some(rec) => {
            format!("recorded scans of {}: its `train` scans, its `val` scans for checkpoints", rec.dir.display())
        }
        None => {
            format!("simulated (virtual Evetac): {}, {}", t.scans().boards(), crate::train::fit::conditions(&t.scans()))
        }
    };
    let started = std::time::Instant::now();
    let augment =
        |img: &[f32], rng: &mut rand_chacha::ChaCha8Rng| crate::train::augment::prepare_augmented(&input, img, rng);
    let start = match init {
        Some(path) => {
            let bad = |what: &str| Error::Model { path: path.to_path_buf(), what: what.into() };
            let pipeline::models::Model::Resnet(m) = pipeline::models::load(path)? else {
                return Err(bad("holds an SNN; a ResNet fine-tunes a ResNet"));
            };
            if m.config != config || m.input != input || m.classes != classes {
                return Err(bad("its preset, input or classes are not this training's: fine-tuning keeps them"));
            }
            Some(m.tensors)
        }
        None => None,
    };
    let (model, history) =
        learn::resnet::train(&config, &train_set, &val, &t.train, &augment, start.as_deref(), observer)?;
    let best = history.iter().map(|h| h.val_accuracy).fold(f64::NAN, f64::max);
    let provenance = serde_json::json!({
        "data": data,
        "init": init.map(|p| p.display().to_string()),
        "realism": t.realism,
        "sensor_builds": world.sensors,
        "task": t.task,
        "jitter_ms": t.jitter_ms,
        "blank_cells": t.blank_cells,
        "word_rows": t.word_rows,
        "letter_rows": t.letter_rows,
        "pair_rows": t.pair_rows,
        "sweep": t.sweep,
        "scans": tw.scans,
        "train_windows": train_set.len(),
        "val_windows": val.len(),
        "train": t.train,
        "best_val_accuracy": best,
        "train_seconds": started.elapsed().as_secs_f64(),
        "peak_rss_mb": crate::peak_rss_mb(),
    });
    Ok(TrainedResnet {
        data: match recordings {
            Some(rec) => format!("recorded scans of {} (`train`; `val` for checkpoints)", rec.dir.display()),
            None => format!(
                "SIMULATED training windows ({} realism): {}, at {}",
                t.realism,
                t.scans().boards(),
                crate::train::fit::conditions(&t.scans())
            ),
        },
        realism: t.realism,
        word_rows: t.word_rows,
        model: ResnetModel {
            config,
            input,
            tensors: learn::resnet::to_tensors(&model)?,
            classes,
            provenance,
            operating_point: None,
        },
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
            "{}: {} scans ({} skipped: window count off), {} training and {} validation windows of {:?}",
            self.data,
            self.scans,
            self.skipped_scans,
            self.train_windows,
            self.val_windows,
            self.model.input.shape()
        )?;
        let kind = if self.data.starts_with("recorded") { "RECORDED" } else { "SIMULATED" };
        writeln!(f, "best validation accuracy {:.2}% ({kind})", 100.0 * self.best_val_accuracy)
    }
}
