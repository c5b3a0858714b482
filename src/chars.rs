//! The character classifiers on simulated scans: `braille train --arch resnet` and
//! `braille eval chars`. Everything here runs on SIMULATED data (the virtual Evetac).

use anyhow::{Context, Result, bail};
use learn::data::SpikeSet;
use learn::resnet::{ImageSet, Resnet, ResnetConfig};
use learn::snn::{SnnParams, SnnTwin};
use pipeline::augment::{AugmentConfig, Preprocess};
use pipeline::chars::{CharSetSpec, Task, scan_seed, scan_windows, scans};
use pipeline::labeling::LabelerConfig;
use rayon::prelude::*;
use serde::Serialize;
use sim::BoardKind;
use snn::engine::Mode;
use snn::model_file::{Arch, ModelFile, SnnModel};
use snn::neuron::Surrogate;
use std::path::{Path, PathBuf};

pub use pipeline::input::{CharInput, LITE_COLS, LITE_ROWS};

/// Windows of `spec`'s scans, simulated in parallel and cropped as soon as their scan is done
/// (so memory holds only the crops); each window's crop, with the scan it came from, the number
/// of scans and the scans skipped. The same spec gives the same windows, whichever model asks.
#[allow(clippy::type_complexity)]
pub fn build(spec: &CharSetSpec, input: &CharInput) -> Result<(ImageSet, Vec<(String, usize, u64)>, usize, usize)> {
    let (mut sets, origin, n_scans, skipped) = build_many(spec, &[input])?;
    Ok((sets.remove(0), origin, n_scans, skipped))
}

/// [`build`] for several models at once: each scan is simulated and labelled once and its windows
/// cropped for every input (which must share one labeler), so all models see the same windows.
#[allow(clippy::type_complexity)]
pub fn build_many(
    spec: &CharSetSpec,
    inputs: &[&CharInput],
) -> Result<(Vec<ImageSet>, Vec<(String, usize, u64)>, usize, usize)> {
    let Some(first) = inputs.first() else { bail!("no model input to build windows for") };
    if inputs.iter().any(|i| i.labeler != first.labeler) {
        bail!("the models label their windows differently; build their windows separately");
    }
    let sensor = crate::simulate::sensor(encoders::Resolution::DVXPLORER, 1)?;
    let list = scans(spec)?;
    let bar = indicatif::ProgressBar::new(list.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("simulating scans [{bar:30}] {pos}/{len} ({elapsed})")
            .expect("template"),
    );
    type Kept = (usize, Vec<Vec<f32>>, (String, usize, u64));
    let per_scan: Vec<Option<Vec<Kept>>> = list
        .par_iter()
        .map(|(board, row, trial)| -> Result<_> {
            let seed = scan_seed(spec.seed, &board.kind, *row, *trial);
            let r = scan_windows(
                board,
                &sensor,
                *row,
                *trial,
                seed,
                spec.speed_mm_s,
                spec.depth_mm,
                &first.labeler,
                spec.task,
                spec.jitter_ms,
            )?;
            bar.inc(1);
            let Some(samples) = r else { return Ok(None) };
            let mut kept = Vec::with_capacity(samples.len());
            for s in samples {
                let crops = inputs.iter().map(|i| Ok(i.crop(&s.map)?.counts)).collect::<Result<_>>()?;
                kept.push((s.class, crops, s.scan));
            }
            Ok(Some(kept))
        })
        .collect::<Result<_>>()?;
    bar.finish_and_clear();
    let mut sets: Vec<ImageSet> = inputs.iter().map(|i| ImageSet { shape: i.shape(), ..ImageSet::default() }).collect();
    let mut origin = Vec::new();
    let skipped = per_scan.iter().filter(|s| s.is_none()).count();
    for (class, crops, scan) in per_scan.into_iter().flatten().flatten() {
        for (set, counts) in sets.iter_mut().zip(crops) {
            set.data.push(counts);
            set.labels.push(class);
        }
        origin.push(scan);
    }
    Ok((sets, origin, list.len(), skipped))
}

/// Words of the EV board, kept out of the random word rows so that EV stays a test board.
pub const EV_WORDS: [&str; 9] = ["RIGHT", "LEFT", "EXIT", "OPEN", "PUSH", "PULL", "STOP", "HELP", "WATER"];

/// The training protocol's windows: SAB and UN at 8 mm/s and 1.5 mm (the paper's), plus
/// `word_rows` rows of random words (beyond the paper: letters with neighbours at the cell
/// spacing, as in words; the single-letter boards spread their letters over the row), split by
/// whole scans (every fifth trial goes to validation when there are five or more), so no scan
/// feeds both.
#[allow(clippy::type_complexity)]
pub fn training_windows(
    trials: u64,
    seed: u64,
    word_rows: usize,
    input: &CharInput,
    task: Task,
    jitter_ms: f64,
) -> Result<(ImageSet, Vec<usize>, Vec<usize>, usize, usize)> {
    let mut boards = vec![BoardKind::Sab, BoardKind::Un];
    if word_rows > 0 {
        let text = pipeline::chars::random_word_rows(seed ^ 0x5745_5244, word_rows, 22, &EV_WORDS);
        boards.push(BoardKind::Text(text));
    }
    let spec = CharSetSpec { boards, speed_mm_s: 8.0, depth_mm: 1.5, trials, seed, task, jitter_ms };
    let (all, origin, n_scans, skipped) = build(&spec, input)?;
    let (val, train): (Vec<usize>, Vec<usize>) = (0..all.len()).partition(|&i| trials >= 5 && origin[i].2 % 5 == 4);
    Ok((all, train, val, n_scans, skipped))
}

/// A trained ResNet and how its input is made.
pub struct ResnetModel {
    pub config: ResnetConfig,
    pub input: CharInput,
    pub model: Resnet,
    pub classes: Vec<String>,
}

impl ResnetModel {
    pub fn save(&self, path: &Path, provenance: serde_json::Value, force: bool) -> Result<()> {
        let tensors = learn::resnet::to_tensors(&self.model).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        ModelFile {
            arch: Arch::Resnet,
            config: serde_json::to_value(&self.config)?,
            preprocess: serde_json::to_value(&self.input)?,
            classes: self.classes.clone(),
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
        if f.classes.len() != config.classes {
            bail!("{}: {} class names for a network of {} outputs", path.display(), f.classes.len(), config.classes);
        }
        Ok(ResnetModel { config, input, model, classes: f.classes })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PresetArg {
    Lite,
    Paper,
    /// The smallest: for the segmentation network, which runs on every frame.
    Tiny,
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
    pub task: Task,
    pub jitter_ms: f64,
    pub pool: usize,
    pub trials: u64,
    pub word_rows: usize,
    pub train: learn::train::TrainConfig,
    pub out: &'a PathBuf,
    pub force: bool,
    pub history: Option<&'a PathBuf>,
    pub observer: &'a mut dyn learn::train::Observer,
}

pub fn train(a: ResnetTrainArgs) -> Result<()> {
    let labeler = LabelerConfig::default();
    let (rows, cols) = match a.preset {
        PresetArg::Lite | PresetArg::Tiny => (LITE_ROWS, LITE_COLS),
        PresetArg::Paper => (0..120, 20..100),
    };
    let pool = if a.preset == PresetArg::Paper { 1 } else { crate::train::check_pool(a.pool)? };
    let input =
        CharInput { labeler, rows, cols, pool, preprocess: a.aug.preprocess(), augment: AugmentConfig::default() };
    let (all, train_idx, val_idx, n_scans, skipped) =
        training_windows(a.trials, a.train.seed, a.word_rows, &input, a.task, a.jitter_ms)?;
    // the windows move into the two sets (no copy: the training set is most of the memory)
    let mut all = all;
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
    let train_set = pick(&train_idx, false);
    let val = pick(&val_idx, true);
    eprintln!(
        "SIMULATED training windows: SAB and UN at 8 mm/s, 1.5 mm, {} rows of random words: {n_scans} scans ({skipped} skipped: window count off), {} training and {} validation windows of {:?}",
        a.word_rows,
        train_set.len(),
        val.len(),
        input.shape()
    );
    let classes = a.task.classes();
    let config = match a.preset {
        PresetArg::Lite => ResnetConfig::lite(input.shape(), classes.len()),
        PresetArg::Paper => ResnetConfig::paper(input.shape(), classes.len()),
        PresetArg::Tiny => ResnetConfig::tiny(input.shape(), classes.len()),
    };
    let started = std::time::Instant::now();
    let augment = |img: &[f32], rng: &mut rand_chacha::ChaCha8Rng| input.prepare(img, Some(rng));
    let (model, history) = learn::resnet::train(&config, &train_set, &val, &a.train, &augment, a.observer);
    let best = history.iter().map(|h| h.val_accuracy).fold(f64::NAN, f64::max);
    let m = ResnetModel { config, input, model, classes };
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    m.save(
        a.out,
        serde_json::json!({
            "data": "simulated (virtual Evetac): SAB and UN boards, 8 mm/s, 1.5 mm",
            "task": a.task,
            "jitter_ms": a.jitter_ms,
            "word_rows": a.word_rows,
            "scans": n_scans,
            "train_windows": train_set.len(),
            "val_windows": val.len(),
            "train": a.train,
            "best_val_accuracy": best,
            "train_seconds": started.elapsed().as_secs_f64(),
            "peak_rss_mb": crate::bench::peak_rss_mb(),
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
    /// The model file [default: the architecture's shipped model, models/resnet-lite-normaug.safetensors
    /// or models/snn-chars.safetensors].
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

/// A character classifier of either architecture, with how its input is made.
#[allow(clippy::large_enum_variant)] // one per process: the size does not matter
pub enum CharModel {
    Resnet(ResnetModel),
    Snn { model: SnnModel, input: CharInput },
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
    /// The shipped default of each architecture.
    pub fn default_path(arch: crate::train::ArchArg) -> PathBuf {
        match arch {
            crate::train::ArchArg::Resnet => PathBuf::from("models/resnet-lite-normaug.safetensors"),
            crate::train::ArchArg::Snn => PathBuf::from("models/snn-chars.safetensors"),
        }
    }

    pub fn load(arch: crate::train::ArchArg, path: &Path) -> Result<CharModel> {
        Ok(match arch {
            crate::train::ArchArg::Resnet => CharModel::Resnet(ResnetModel::load(path)?),
            crate::train::ArchArg::Snn => {
                let model = SnnModel::load(path)?;
                let input: CharInput = serde_json::from_value(model.preprocess.clone()).with_context(|| {
                    format!(
                        "{}: header `preprocess` is not a character-window input (a model for `eval --data`?)",
                        path.display()
                    )
                })?;
                let n = 2 * input.shape()[1] * input.shape()[2];
                if model.config.network.input_shape.iter().product::<usize>() != n {
                    bail!(
                        "{}: the preprocessing gives {n} inputs, the network takes {:?}",
                        path.display(),
                        model.config.network.input_shape
                    );
                }
                CharModel::Snn { model, input }
            }
        })
    }

    pub fn input(&self) -> &CharInput {
        match self {
            CharModel::Resnet(m) => &m.input,
            CharModel::Snn { input, .. } => input,
        }
    }

    pub fn arch(&self) -> &'static str {
        match self {
            CharModel::Resnet(_) => "resnet",
            CharModel::Snn { .. } => "snn",
        }
    }

    /// Scores the windows of `raw` (crops as [`build`] makes them for this model).
    pub fn score(&self, raw: &ImageSet) -> Result<Score> {
        match self {
            CharModel::Resnet(m) => {
                let mut confusion = vec![vec![0u32; 26]; 26];
                let set = ImageSet {
                    shape: raw.shape,
                    data: raw.data.par_iter().map(|d| m.input.prepare(d, None)).collect(),
                    labels: raw.labels.clone(),
                };
                let (loss, accuracy, preds) = learn::resnet::evaluate(&m.model, &set, 32);
                for (&p, &l) in preds.iter().zip(&set.labels) {
                    confusion[l][p] += 1;
                }
                Ok(Score {
                    n: set.len(),
                    accuracy,
                    macro_f1: macro_f1(&confusion),
                    loss,
                    confusion,
                    synops_per_sample: None,
                    spikes_per_sample: None,
                    input_events_per_sample: None,
                    accuracy_async: None,
                })
            }
            CharModel::Snn { model, input } => {
                let set = snn_set(input, raw, &(0..raw.len()).collect::<Vec<_>>(), model.config.dt_us, Task::Chars);
                let stepped = crate::eval::snn_accuracy_in(&model.network, &model.config, &set, Mode::Stepped)?;
                let accuracy_async = if async_capable(&model.network, model.config.dt_us) {
                    Some(crate::eval::snn_accuracy_in(&model.network, &model.config, &set, Mode::Async)?.accuracy)
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
                    macro_f1: macro_f1(&stepped.confusion),
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

/// Whether the engine's async mode runs this network (the engine's own rule: LIF and IF layers
/// without bias or recurrence).
pub fn async_capable(network: &snn::network::Network, dt_us: i64) -> bool {
    snn::engine::Engine::new(network, dt_us, Mode::Async).is_ok()
}

/// The windows `idx` of `raw` as labelled spike trains for an SNN.
pub fn snn_set(input: &CharInput, raw: &ImageSet, idx: &[usize], dt_us: i64, task: Task) -> SpikeSet {
    let [frames2, h, w] = input.shape();
    SpikeSet {
        n_inputs: 2 * h * w,
        steps: frames2 / 2,
        dt_us,
        classes: task.classes(),
        trains: idx.par_iter().map(|&i| input.spikes(&raw.data[i], dt_us)).collect(),
        labels: idx.iter().map(|&i| raw.labels[i]).collect(),
        dropped_events: 0,
    }
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
    #[serde(flatten)]
    score: Score,
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
    let path = args.model.clone().unwrap_or_else(|| CharModel::default_path(args.arch));
    let m = CharModel::load(args.arch, &path)?;
    let spec = CharSetSpec {
        boards: vec![args.board.clone()],
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        task: Task::Chars,
        jitter_ms: 0.0,
    };
    let (raw, _, scans, skipped) = build(&spec, m.input())?;
    let r = CharReport {
        data: "simulated (virtual Evetac)",
        arch: m.arch(),
        model: path.display().to_string(),
        board: args.board.name(),
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        scans,
        skipped_scans: skipped,
        score: m.score(&raw)?,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        println!(
            "SIMULATED {} at {} mm/s, {} mm: {} windows from {} scans ({} skipped): {} accuracy {:.2}%, macro F1 {:.3}, loss {:.3}{}",
            r.board,
            r.speed_mm_s,
            r.depth_mm,
            r.score.n,
            r.scans,
            r.skipped_scans,
            r.arch,
            100.0 * r.score.accuracy,
            r.score.macro_f1,
            r.score.loss,
            r.score.accuracy_async.map_or(String::new(), |a| format!(" (async engine {:.2}%)", 100.0 * a))
        );
    }
    Ok(())
}
