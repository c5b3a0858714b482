//! The character classifiers on simulated scans: `braille train --arch resnet` and
//! `braille eval chars`. Everything here runs on SIMULATED data (the virtual Evetac).

use anyhow::{Context, Result, bail};
use encoders::heatmap::Heatmap;
use learn::resnet::{ImageSet, Resnet, ResnetConfig};
use pipeline::augment::{AugmentConfig, Preprocess, prepare};
use pipeline::chars::{CharSample, CharSetSpec, class_of, scan_seed, scan_windows, scans};
use pipeline::labeling::LabelerConfig;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sim::BoardKind;
use snn::model_file::{Arch, ModelFile};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// How windows become network input, as the model file records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharInput {
    pub labeler: LabelerConfig,
    /// Pooled rows and columns kept (the labeler masks columns outside 20-100 anyway).
    pub rows: Range<usize>,
    pub cols: Range<usize>,
    pub preprocess: Preprocess,
    pub augment: AugmentConfig,
}

impl CharInput {
    pub fn shape(&self) -> [usize; 3] {
        [self.labeler.frames * 2, self.rows.len(), self.cols.len()]
    }

    /// The window's counts, cropped, as a heat map of the crop.
    pub fn crop(&self, map: &Heatmap) -> Result<Heatmap> {
        if self.rows.end > map.height || self.cols.end > map.width || map.bins != self.labeler.frames {
            bail!(
                "a window of {} bins x {}x{} does not fit the model's input (rows {:?}, columns {:?}, {} bins)",
                map.bins,
                map.height,
                map.width,
                self.rows,
                self.cols,
                self.labeler.frames
            );
        }
        let (h, w) = (self.rows.len(), self.cols.len());
        let mut counts = Vec::with_capacity(map.bins * 2 * h * w);
        for plane in 0..map.bins * 2 {
            for r in self.rows.clone() {
                let at = (plane * map.height + r) * map.width;
                counts.extend_from_slice(&map.counts[at + self.cols.start..at + self.cols.end]);
            }
        }
        Ok(Heatmap { t_start_us: map.t_start_us, bin_us: map.bin_us, bins: map.bins, height: h, width: w, counts })
    }

    /// The cropped counts of an image as a heat map again.
    fn as_map(&self, image: &[f32]) -> Heatmap {
        Heatmap {
            t_start_us: 0,
            bin_us: 1,
            bins: self.labeler.frames,
            height: self.rows.len(),
            width: self.cols.len(),
            counts: image.to_vec(),
        }
    }

    /// Network input of a cropped image: centred and normalised as configured; augmented when
    /// `rng` is given.
    pub fn prepare(&self, image: &[f32], rng: Option<&mut rand_chacha::ChaCha8Rng>) -> Vec<f32> {
        let rng = rng.map(|r| r as &mut dyn rand::RngCore);
        prepare(&self.as_map(image), self.preprocess, &self.augment, rng).counts
    }
}

/// Windows of `spec`'s scans, simulated in parallel; each window's crop, with the scan it came
/// from, the number of scans and the scans skipped.
#[allow(clippy::type_complexity)]
pub fn build(spec: &CharSetSpec, input: &CharInput) -> Result<(ImageSet, Vec<(String, usize, u64)>, usize, usize)> {
    let sensor = crate::simulate::sensor(encoders::Resolution::DVXPLORER, 1)?;
    let list = scans(spec)?;
    let bar = indicatif::ProgressBar::new(list.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("simulating scans [{bar:30}] {pos}/{len} ({elapsed})")
            .expect("template"),
    );
    let per_scan: Vec<Option<Vec<CharSample>>> = list
        .par_iter()
        .map(|(board, row, trial)| {
            let seed = scan_seed(spec.seed, &board.kind, *row, *trial);
            let r = scan_windows(board, &sensor, *row, *trial, seed, spec.speed_mm_s, spec.depth_mm, &input.labeler);
            bar.inc(1);
            r
        })
        .collect::<pipeline::error::Result<_>>()?;
    bar.finish_and_clear();
    let mut set = ImageSet { shape: input.shape(), ..ImageSet::default() };
    let mut origin = Vec::new();
    let skipped = per_scan.iter().filter(|s| s.is_none()).count();
    for s in per_scan.into_iter().flatten().flatten() {
        let Some(class) = class_of(s.letter) else { continue };
        set.data.push(input.crop(&s.map)?.counts);
        set.labels.push(class);
        origin.push(s.scan);
    }
    Ok((set, origin, list.len(), skipped))
}

pub fn classes() -> Vec<String> {
    (b'A'..=b'Z').map(|c| (c as char).to_string()).collect()
}

/// A trained ResNet and how its input is made.
pub struct ResnetModel {
    pub config: ResnetConfig,
    pub input: CharInput,
    pub model: Resnet,
}

impl ResnetModel {
    pub fn save(&self, path: &Path, provenance: serde_json::Value, force: bool) -> Result<()> {
        let tensors = learn::resnet::to_tensors(&self.model).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        ModelFile {
            arch: Arch::Resnet,
            config: serde_json::to_value(&self.config)?,
            preprocess: serde_json::to_value(&self.input)?,
            classes: classes(),
            provenance,
            tensors,
        }
        .write(path, force)?;
        Ok(())
    }

    pub fn load(path: &Path) -> Result<ResnetModel> {
        let f = ModelFile::read(path, Arch::Resnet)?;
        let config: ResnetConfig =
            serde_json::from_value(f.config.clone()).with_context(|| format!("{}: header `config`", path.display()))?;
        let input: CharInput = serde_json::from_value(f.preprocess.clone())
            .with_context(|| format!("{}: header `preprocess`", path.display()))?;
        if input.shape() != config.input {
            bail!(
                "{}: the preprocessing gives {:?}, the network takes {:?}",
                path.display(),
                input.shape(),
                config.input
            );
        }
        let model =
            learn::resnet::from_tensors(&config, &f.tensors).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Ok(ResnetModel { config, input, model })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PresetArg {
    Lite,
    Paper,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AugArg {
    Raw,
    Norm,
    Aug,
    Normaug,
}

impl AugArg {
    pub fn preprocess(self) -> Preprocess {
        match self {
            AugArg::Raw => Preprocess::Raw,
            AugArg::Norm => Preprocess::Norm,
            AugArg::Aug => Preprocess::Aug,
            AugArg::Normaug => Preprocess::NormAug,
        }
    }
}

/// What `braille train --arch resnet` takes (beside the shared epochs, batch, lr, seed, out).
pub struct ResnetTrainArgs<'a> {
    pub preset: PresetArg,
    pub aug: AugArg,
    pub trials: u64,
    pub train: learn::train::TrainConfig,
    pub out: &'a PathBuf,
    pub force: bool,
    pub history: Option<&'a PathBuf>,
    pub observer: &'a mut dyn learn::train::Observer,
}

pub fn train(a: ResnetTrainArgs) -> Result<()> {
    let labeler = LabelerConfig::default();
    let (rows, cols) = match a.preset {
        // the dots of one Braille row fill the middle of the image; the lite network sees them
        PresetArg::Lite => (28..92, 20..100),
        PresetArg::Paper => (0..120, 20..100),
    };
    let input = CharInput { labeler, rows, cols, preprocess: a.aug.preprocess(), augment: AugmentConfig::default() };
    let spec = CharSetSpec {
        boards: vec![BoardKind::Sab, BoardKind::Un],
        speed_mm_s: 8.0,
        depth_mm: 1.5,
        trials: a.trials,
        seed: a.train.seed,
    };
    let (all, origin, n_scans, skipped) = build(&spec, &input)?;
    // Whole scans go to validation (every fifth trial), so no scan feeds both sides.
    let val_idx: Vec<usize> = (0..all.len()).filter(|&i| a.trials >= 5 && origin[i].2 % 5 == 4).collect();
    let pick = |idx: &[usize], set: &ImageSet, prepared: bool| ImageSet {
        shape: set.shape,
        data: idx
            .iter()
            .map(|&i| if prepared { input.prepare(&set.data[i], None) } else { set.data[i].clone() })
            .collect(),
        labels: idx.iter().map(|&i| set.labels[i]).collect(),
    };
    let train_idx: Vec<usize> = (0..all.len()).filter(|i| !val_idx.contains(i)).collect();
    let train_set = pick(&train_idx, &all, false);
    let val = pick(&val_idx, &all, true);
    eprintln!(
        "SIMULATED training windows: SAB and UN at 8 mm/s, 1.5 mm: {n_scans} scans ({skipped} skipped: window count off), {} training and {} validation windows of {:?}",
        train_set.len(),
        val.len(),
        input.shape()
    );
    let config = match a.preset {
        PresetArg::Lite => ResnetConfig::lite(input.shape(), 26),
        PresetArg::Paper => ResnetConfig::paper(input.shape(), 26),
    };
    let started = std::time::Instant::now();
    let augment = |img: &[f32], rng: &mut rand_chacha::ChaCha8Rng| input.prepare(img, Some(rng));
    let (model, history) = learn::resnet::train(&config, &train_set, &val, &a.train, &augment, a.observer);
    let best = history.iter().map(|h| h.val_accuracy).fold(f64::NAN, f64::max);
    let m = ResnetModel { config, input, model };
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    m.save(
        a.out,
        serde_json::json!({
            "data": "simulated (virtual Evetac): SAB and UN boards, 8 mm/s, 1.5 mm",
            "scans": n_scans,
            "train_windows": train_set.len(),
            "val_windows": val.len(),
            "train": a.train,
            "best_val_accuracy": best,
            "train_seconds": started.elapsed().as_secs_f64(),
        }),
        a.force,
    )?;
    if let Some(h) = a.history {
        crate::simulate::write_json(h, &history, a.force)?;
    }
    eprintln!("best validation accuracy {:.2}% (SIMULATED); wrote {}", 100.0 * best, a.out.display());
    Ok(())
}

#[derive(clap::Args)]
pub struct EvalCharsArgs {
    #[arg(long, value_enum, default_value = "resnet")]
    arch: crate::train::ArchArg,
    /// The model file [default: models/resnet-lite-normaug.safetensors].
    #[arg(long)]
    model: Option<PathBuf>,
    #[arg(long, default_value = "RAB")]
    board: BoardKind,
    #[arg(long, default_value_t = 8.0)]
    speed: f64,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    /// Scans per board row.
    #[arg(long, default_value_t = 4)]
    trials: u64,
    /// Scan seed (training used seeds from its own; the default keeps test scans apart).
    #[arg(long, default_value_t = 1_000_003)]
    seed: u64,
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct CharReport {
    data: &'static str,
    arch: &'static str,
    model: String,
    board: String,
    speed_mm_s: f64,
    depth_mm: f64,
    scans: usize,
    skipped_scans: usize,
    n: usize,
    accuracy: f64,
    macro_f1: f64,
    loss: f64,
    confusion: Vec<Vec<u32>>,
}

/// Macro-averaged F1 over the classes that occur (in truth or prediction).
pub fn macro_f1(confusion: &[Vec<u32>]) -> f64 {
    let k = confusion.len();
    let mut f1s = Vec::new();
    #[allow(clippy::needless_range_loop)]
    for c in 0..k {
        let tp = confusion[c][c] as f64;
        let fp: f64 = (0..k).filter(|&r| r != c).map(|r| confusion[r][c] as f64).sum();
        let fn_: f64 = (0..k).filter(|&p| p != c).map(|p| confusion[c][p] as f64).sum();
        if tp + fp + fn_ > 0.0 {
            f1s.push(2.0 * tp / (2.0 * tp + fp + fn_));
        }
    }
    if f1s.is_empty() { 0.0 } else { f1s.iter().sum::<f64>() / f1s.len() as f64 }
}

pub fn eval(args: EvalCharsArgs) -> Result<()> {
    if args.arch != crate::train::ArchArg::Resnet {
        bail!(
            "`eval chars --arch snn` needs the SNN trained on simulated windows, which is not built yet; use --arch resnet"
        );
    }
    let path = args.model.clone().unwrap_or_else(|| PathBuf::from("models/resnet-lite-normaug.safetensors"));
    let m = ResnetModel::load(&path)?;
    let spec = CharSetSpec {
        boards: vec![args.board.clone()],
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
    };
    let (raw, _, scans, skipped) = build(&spec, &m.input)?;
    let set = ImageSet {
        shape: raw.shape,
        data: raw.data.iter().map(|d| m.input.prepare(d, None)).collect(),
        labels: raw.labels,
    };
    let (loss, accuracy, preds) = learn::resnet::evaluate(&m.model, &set, 32);
    let mut confusion = vec![vec![0u32; 26]; 26];
    for (&p, &l) in preds.iter().zip(&set.labels) {
        confusion[l][p] += 1;
    }
    let r = CharReport {
        data: "simulated (virtual Evetac)",
        arch: "resnet",
        model: path.display().to_string(),
        board: args.board.name(),
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        scans,
        skipped_scans: skipped,
        n: set.len(),
        accuracy,
        macro_f1: macro_f1(&confusion),
        loss,
        confusion,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        println!(
            "SIMULATED {} at {} mm/s, {} mm: {} windows from {} scans ({} skipped): accuracy {:.2}%, macro F1 {:.3}, loss {:.3}",
            r.board,
            r.speed_mm_s,
            r.depth_mm,
            r.n,
            r.scans,
            r.skipped_scans,
            100.0 * r.accuracy,
            r.macro_f1,
            r.loss
        );
    }
    Ok(())
}
