//! `braille calibrate-reader`: a segmentation network's operating point (threshold, shortest
//! segment) chosen on the validation words, written as Markdown and JSON, and with `--write`
//! into the network's model file, where every reader of it reads it. With `--braille ueb-g1|ueb-g2`
//! the cell readers' network (models/REALISM/ueb/, shared by both architectures) on the validation
//! sentences, one point for both.

use crate::common::Bar;
use anyhow::{Context, Result};
use experiments::eval::calibrate::{Calibration, CalibrationSpec, calibrate, markdown};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::OperatingPoint;
use snn::model_file::Arch;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// The architecture whose shipped pair is calibrated (its segmentation network and the
    /// classifier that reads words with it).
    #[arg(long, value_enum, default_value_t = Arch::Snn)]
    arch: Arch,
    /// The folder of the architecture's pair [default: the models trained at `--realism`].
    #[arg(long)]
    models: Option<PathBuf>,
    /// The segmentation network [default: the architecture's in the models folder].
    #[arg(long)]
    segmenter: Option<PathBuf>,
    /// The character classifier read with it [default: the architecture's].
    #[arg(long)]
    classifier: Option<PathBuf>,
    /// The Braille code the readers read: the paper's letters (the validation words), or
    /// `ueb-g1`/`ueb-g2`: the cell readers of models/REALISM/ueb/, whose segmentation network
    /// both architectures share, calibrated together on VAL-UEB (the validation sentences, 1.0
    /// mm): one point, chosen by the rule on the mean of both readers' scores; `--arch`,
    /// `--segmenter`, `--classifier` and `--recordings` do not apply, and the grid is written as
    /// `operating_point_CODE.md` and `.json` in `--out`/ueb/.
    #[arg(long, value_enum, default_value = "grade1-letters")]
    braille: pipeline::code::BrailleCode,
    /// Scans per row of the validation words and speed [default: 12 for the words, 3 for the
    /// sentences].
    #[arg(long)]
    trials: Option<u64>,
    /// Speeds, mm/s [default: 8,16,32,64 for the words, 8,16,32 for the sentences].
    #[arg(long, value_delimiter = ',')]
    speeds: Option<Vec<f64>>,
    /// Thresholds of the segmentation network's "character" probability.
    #[arg(long, value_delimiter = ',', default_value = "0.3,0.4,0.5,0.6,0.7,0.8,0.85,0.9,0.95")]
    thresholds: Vec<f32>,
    /// Shortest segments, in frames.
    #[arg(long, value_delimiter = ',', default_value = "2,3,4,5,6,8,10,12")]
    min_frames: Vec<usize>,
    /// Write `operating_point_ARCH.md` and `.json` here [default: docs/results/REALISM/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Record the chosen point in the segmentation network's model file (its weights unchanged).
    #[arg(long)]
    write: bool,
    /// Sweep nothing: record the point chosen by an earlier run (its `operating_point_ARCH.json`)
    /// in the segmentation network's model file.
    #[arg(long, conflicts_with = "write")]
    apply: Option<PathBuf>,
    /// Choose on a lab's recordings folder (docs/recordings.md) instead of the simulated
    /// validation words: its `val` scans, grouped by commanded speed; `--trials` and `--speeds`
    /// do not apply.
    #[arg(long)]
    recordings: Option<PathBuf>,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

pub fn run(args: Args) -> Result<()> {
    if args.braille != pipeline::code::BrailleCode::Grade1Letters {
        return run_cells(args);
    }
    let dir = args.models.clone().unwrap_or_else(|| args.realism.models_dir());
    let pipeline::shipped::ReaderFiles { segmenter: s, classifier: c } = pipeline::shipped::reader_in(&dir, args.arch);
    let s_path = args.segmenter.clone().unwrap_or(s);
    let c_path = args.classifier.clone().unwrap_or(c);
    if let Some(json) = &args.apply {
        return record(&s_path, &experiments::eval::calibrate::chosen_in(json)?);
    }
    let models = ReaderModels::load(&s_path, &c_path, SnnRunner::Sliding)?;
    let spec = grid_of(&args, CalibrationSpec::validation(args.realism.realism));
    let r = match &args.recordings {
        Some(dir) => experiments::eval::calibrate::calibrate_recordings(
            &models,
            &name(&s_path),
            &name(&c_path),
            &corpus::recordings::Recordings::open(dir)?,
            &args.thresholds,
            &args.min_frames,
            &Bar::default(),
        )?,
        None => calibrate(&models, &name(&s_path), &name(&c_path), &spec, &Bar::default())?,
    };
    let out = args.out.clone().unwrap_or_else(|| args.realism.results_dir());
    let stem = out.join(format!("operating_point_{}", args.arch));
    let written = Written { joint: &r, each: &[] };
    conclude(&args, &s_path, &r.chosen, "", &stem, &markdown(&r), &written)
}

/// `--braille ueb-g1|ueb-g2`: the shared segmentation network of the cell readers, calibrated on
/// the validation sentences with both architectures' classifiers.
fn run_cells(args: Args) -> Result<()> {
    if args.recordings.is_some() || args.segmenter.is_some() || args.classifier.is_some() {
        anyhow::bail!(
            "--braille {}: the cell readers' shared network is calibrated on the simulated validation sentences with both architectures' classifiers of the models folder; --recordings, --segmenter and --classifier do not apply",
            args.braille
        );
    }
    let dir = args.models.clone().unwrap_or_else(|| args.realism.models_dir());
    let archs = [Arch::Snn, Arch::Resnet];
    let files: Vec<pipeline::shipped::ReaderFiles> =
        archs.iter().map(|&a| pipeline::shipped::reader_for(&dir, a, args.braille)).collect();
    let s_path = files[0].segmenter.clone();
    if files.iter().any(|f| f.segmenter != s_path) {
        anyhow::bail!("the cell readers of {} do not share one segmentation network", dir.display());
    }
    if let Some(json) = &args.apply {
        return record(&s_path, &experiments::eval::calibrate::chosen_in(json)?);
    }
    let readers: Vec<ReaderModels> = files
        .iter()
        .map(|f| ReaderModels::load(&f.segmenter, &f.classifier, SnnRunner::Sliding))
        .collect::<pipeline::Result<_>>()?;
    let names: Vec<String> = files.iter().map(|f| name(&f.classifier)).collect();
    let pairs: Vec<(&ReaderModels, &str)> = readers.iter().zip(&names).map(|(r, n)| (r, n.as_str())).collect();
    let spec = grid_of(&args, CalibrationSpec::validation_in(args.realism.realism, args.braille)?);
    let (joint, each) = experiments::eval::calibrate::calibrate_shared(&pairs, &name(&s_path), &spec, &Bar::default())?;
    let out = args.out.clone().unwrap_or_else(|| args.realism.results_dir().join("ueb"));
    let stem = out.join(format!("operating_point_{}", args.braille));
    let mut md = markdown(&joint);
    for (arch, c) in archs.iter().zip(&each) {
        md += &format!("\n## {arch} alone ({})\n\n", c.classifier);
        md += markdown(c).split_once("\n\n").map_or("", |(_, body)| body);
    }
    conclude(
        &args,
        &s_path,
        &joint.chosen,
        " (both architectures)",
        &stem,
        &md,
        &Written { joint: &joint, each: &each },
    )
}

/// What a calibration writes as JSON: the (joint) calibration, and with a shared network each
/// reader's own beside it.
#[derive(serde::Serialize)]
struct Written<'a> {
    #[serde(flatten)]
    joint: &'a Calibration,
    #[serde(skip_serializing_if = "<[Calibration]>::is_empty")]
    each: &'a [Calibration],
}

/// The calibration's grid as `stem`.md and `stem`.json, the chosen point printed (`whose`: for
/// which readers) and, with `--write`, recorded in the segmentation network at `s_path`.
fn conclude(
    args: &Args,
    s_path: &Path,
    chosen: &OperatingPoint,
    whose: &str,
    stem: &Path,
    md: &str,
    written: &Written,
) -> Result<()> {
    if let Some(out) = stem.parent() {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    }
    std::fs::write(stem.with_extension("md"), md).with_context(|| format!("writing {}.md", stem.display()))?;
    std::fs::write(stem.with_extension("json"), serde_json::to_string_pretty(written)? + "\n")
        .with_context(|| format!("writing {}.json", stem.display()))?;
    let c = chosen.calibration.as_ref();
    println!(
        "chosen for {}{whose}: threshold {}, {} frames (mean word accuracy {:.3} without spelling, {:.3} with the lexicon); {}.md",
        s_path.display(),
        chosen.present_threshold,
        chosen.min_frames,
        c.map_or(f64::NAN, |c| c.mean_word_accuracy_none),
        c.map_or(f64::NAN, |c| c.mean_word_accuracy_lexicon),
        stem.display()
    );
    if args.write {
        record(s_path, chosen)?;
    }
    Ok(())
}

/// `base` with the command line's grid, and its scans and speeds where given.
fn grid_of(args: &Args, base: CalibrationSpec) -> CalibrationSpec {
    CalibrationSpec {
        trials: args.trials.unwrap_or(base.trials),
        speeds_mm_s: args.speeds.clone().unwrap_or_else(|| base.speeds_mm_s.clone()),
        thresholds: args.thresholds.clone(),
        min_frames: args.min_frames.clone(),
        ..base
    }
}

/// A model file's name, for the records.
fn name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Writes `point` into the model file at `path` (header only; the weights are written back as
/// they were read).
fn record(path: &std::path::Path, point: &OperatingPoint) -> Result<()> {
    experiments::eval::calibrate::record(path, point)?;
    println!("recorded in {}: threshold {}, {} frames", path.display(), point.present_threshold, point.min_frames);
    Ok(())
}
