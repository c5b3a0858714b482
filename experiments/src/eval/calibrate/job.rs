//! One calibration as `braille calibrate-reader` asks for it: the architecture's pair (or the
//! cell readers' shared segmentation network with both architectures' classifiers) swept on the
//! validation scans or a lab's recordings, the grid written as Markdown and JSON, and the chosen
//! point recorded in the segmentation network's model file when asked.

use super::abstain::{self, AbstainSpec, calibrate_abstention};
use super::{Calibration, CalibrationSpec, calibrate, calibrate_recordings, calibrate_shared, markdown};
use crate::{Error, Progress, Result};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::code::BrailleCode;
use pipeline::reader::{Abstention, OperatingPoint};
use pipeline::shipped::{ReaderFiles, Shipped};
use sim::Realism;
use snn::model_file::Arch;
use std::path::{Path, PathBuf};

/// What to calibrate, on what grid, and where the results go (with the `clap` feature,
/// `braille calibrate-reader`'s arguments).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct CalibrateJob {
    /// The architecture whose shipped pair is calibrated (its segmentation network and the
    /// classifier that reads words with it).
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = Arch::Snn))]
    pub arch: Arch,
    /// The simulator's preset of the validation scans and of the default models.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = Realism::Nominal))]
    pub realism: Realism,
    /// The folder of the architecture's pair [default: the models trained at `--realism`].
    #[cfg_attr(feature = "clap", arg(long))]
    pub models: Option<PathBuf>,
    /// The segmentation network [default: the architecture's in the models folder].
    #[cfg_attr(feature = "clap", arg(long))]
    pub segmenter: Option<PathBuf>,
    /// The character classifier read with it [default: the architecture's].
    #[cfg_attr(feature = "clap", arg(long))]
    pub classifier: Option<PathBuf>,
    /// The Braille code the readers read: the paper's letters (the validation words), or
    /// `ueb-g1`/`ueb-g2`: the cell readers of models/REALISM/ueb/, whose segmentation network
    /// both architectures share, calibrated together on VAL-UEB (the validation sentences, 1.0
    /// mm): one point, chosen by the rule on the mean of both readers' scores; `--arch`,
    /// `--segmenter`, `--classifier` and `--recordings` do not apply, and the grid is written as
    /// `operating_point_CODE.md` and `.json` [default: in docs/results/REALISM/ueb/].
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "grade1-letters"))]
    pub braille: BrailleCode,
    /// Scans per row of the validation words and speed [default: 12 for the words, 3 for the
    /// sentences].
    #[cfg_attr(feature = "clap", arg(long))]
    pub trials: Option<u64>,
    /// Speeds, mm/s [default: 8,16,32,64 for the words, 8,16,32 for the sentences].
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ','))]
    pub speeds: Option<Vec<f64>>,
    /// Thresholds of the segmentation network's "character" probability.
    #[cfg_attr(
        feature = "clap",
        arg(long, value_delimiter = ',', default_value = "0.3,0.4,0.5,0.6,0.7,0.8,0.85,0.9,0.95")
    )]
    pub thresholds: Vec<f32>,
    /// Shortest segments, in frames.
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ',', default_value = "2,3,4,5,6,8,10,12"))]
    pub min_frames: Vec<usize>,
    /// Choose on a lab's recordings folder (docs/recordings.md) instead of the simulated
    /// validation words: its `val` scans, grouped by commanded speed; `--trials` and `--speeds`
    /// do not apply.
    #[cfg_attr(feature = "clap", arg(long))]
    pub recordings: Option<PathBuf>,
    /// Write `operating_point_ARCH.md` and `.json` here [default: docs/results/REALISM/].
    #[cfg_attr(feature = "clap", arg(long))]
    pub out: Option<PathBuf>,
    /// Record the chosen point in the segmentation network's model file (its weights unchanged).
    #[cfg_attr(feature = "clap", arg(long))]
    pub write: bool,
    /// Keep the point the model file records and choose only where its reader abstains: the
    /// least lexicon score per letter of a word it gives out (`pipeline::abstain`), on the validation words
    /// and sentences at `nominal` and `harsh`, 8-200 mm/s, 0.6-1.5 mm, by the rule in
    /// docs/protocol.md; written as `abstention_ARCH.md` and `.json`. The paper's letters only.
    #[cfg_attr(feature = "clap", arg(long, conflicts_with_all = ["recordings", "thresholds", "min_frames"]))]
    pub abstain: bool,
    /// With `--abstain`: the least lexicon scores per letter tried (natural log; no abstention is always
    /// tried).
    #[cfg_attr(
        feature = "clap",
        arg(
            long,
            value_delimiter = ',',
            allow_hyphen_values = true,
            default_value = "-1.5,-2,-2.25,-2.5,-2.75,-3,-3.5,-4,-5"
        )
    )]
    pub abstain_scores: Vec<f64>,
}

impl CalibrateJob {
    /// The folder of the pairs: `models`, else `shipped`'s at the preset.
    pub fn models_dir(&self, shipped: &Shipped) -> PathBuf {
        self.models.clone().unwrap_or_else(|| shipped.root().join(self.realism.to_string()))
    }

    /// The validation scans of the code at the preset, with the job's grid.
    pub fn spec(&self) -> Result<CalibrationSpec> {
        let base = CalibrationSpec::validation_in(self.realism, self.braille)?;
        Ok(CalibrationSpec {
            trials: self.trials.unwrap_or(base.trials),
            speeds_mm_s: self.speeds.clone().unwrap_or_else(|| base.speeds_mm_s.clone()),
            thresholds: self.thresholds.clone(),
            min_frames: self.min_frames.clone(),
            ..base
        })
    }

    /// The folder of the grid's files.
    fn out_dir(&self) -> Result<PathBuf> {
        self.out.clone().ok_or_else(|| Error::Options("no folder for the grid (`out`)".into()))
    }
}

/// What a calibration wrote and chose.
pub struct Calibrated {
    /// The segmentation network the point is for.
    pub segmenter: PathBuf,
    pub chosen: OperatingPoint,
    /// For whom: "" (one pair) or " (both architectures)".
    pub whose: &'static str,
    /// The grid's files, without their extension.
    pub stem: PathBuf,
    pub written: bool,
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

/// A model file's name, for the records.
fn name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Runs the calibration with the pairs of `shipped` (or the job's), writes its grid and, with
/// `write`, records the chosen point.
pub fn run(job: &CalibrateJob, shipped: &Shipped, progress: &dyn Progress) -> Result<Calibrated> {
    let models = job.models_dir(shipped);
    if job.braille != BrailleCode::Grade1Letters {
        if job.abstain {
            return Err(Error::Options(format!(
                "--abstain judges words of the paper's letters; the {} readers' words are not judged",
                job.braille
            )));
        }
        return run_cells(job, &models, progress);
    }
    let ReaderFiles { segmenter: s, classifier: c } = pipeline::shipped::reader_in(&models, job.arch);
    let s_path = job.segmenter.clone().unwrap_or(s);
    let c_path = job.classifier.clone().unwrap_or(c);
    let mut models = ReaderModels::load(&s_path, &c_path, SnnRunner::Sliding)?;
    let (s_name, c_name) = (name(&s_path), name(&c_path));
    if job.abstain {
        return run_abstain(job, &mut models, s_path, (&s_name, &c_name), progress);
    }
    let r = match &job.recordings {
        Some(dir) => {
            let rec = corpus::recordings::Recordings::open(dir)?;
            let (thresholds, min_frames) = (&job.thresholds, &job.min_frames);
            calibrate_recordings(&models, &s_name, &c_name, &rec, thresholds, min_frames, progress)?
        }
        None => calibrate(&models, &s_name, &c_name, &job.spec()?, progress)?,
    };
    let stem = job.out_dir()?.join(format!("operating_point_{}", job.arch));
    conclude(job, s_path, r.chosen.clone(), "", stem, &markdown(&r), &Written { joint: &r, each: &[] })
}

/// The abstention of the pair's recorded point: every threshold read on the same validation
/// scans, the table written, and with `write` the chosen threshold recorded with the point.
fn run_abstain(
    job: &CalibrateJob,
    models: &mut ReaderModels,
    s_path: PathBuf,
    names: (&str, &str),
    progress: &dyn Progress,
) -> Result<Calibrated> {
    let mut point = models.operating_point().clone();
    // read with the abstention off, whatever the file recorded
    point.abstain = None;
    models.segmenter.set_operating_point(Some(point.clone()));
    let spec = AbstainSpec::validation(job.abstain_scores.clone());
    let c = calibrate_abstention(models, job.arch, names, &spec, progress)?;
    point.abstain = c.chosen_threshold().map(|t| Abstention {
        min_score_per_char: t,
        chosen_by: format!("braille calibrate-reader --abstain: {} (SIMULATED validation data)", abstain::RULE),
    });
    let stem = job.out_dir()?.join(format!("abstention_{}", job.arch));
    conclude(job, s_path, point, "", stem, &abstain::markdown(&c), &c)
}

/// The cell readers' shared segmentation network, calibrated on the validation sentences with
/// both architectures' classifiers.
fn run_cells(job: &CalibrateJob, models: &Path, progress: &dyn Progress) -> Result<Calibrated> {
    if job.recordings.is_some() || job.segmenter.is_some() || job.classifier.is_some() {
        return Err(Error::Options(format!(
            "--braille {}: the cell readers' shared network is calibrated on the simulated validation sentences with both architectures' classifiers of the models folder; --recordings, --segmenter and --classifier do not apply",
            job.braille
        )));
    }
    let archs = [Arch::Snn, Arch::Resnet];
    let files: Vec<ReaderFiles> =
        archs.iter().map(|&a| pipeline::shipped::reader_for(models, a, job.braille)).collect();
    let s_path = files[0].segmenter.clone();
    if files.iter().any(|f| f.segmenter != s_path) {
        return Err(Error::Options(format!(
            "the cell readers of {} do not share one segmentation network",
            models.display()
        )));
    }
    let readers: Vec<ReaderModels> = files
        .iter()
        .map(|f| ReaderModels::load(&f.segmenter, &f.classifier, SnnRunner::Sliding))
        .collect::<pipeline::Result<_>>()?;
    let names: Vec<String> = files.iter().map(|f| name(&f.classifier)).collect();
    let pairs: Vec<(&ReaderModels, &str)> = readers.iter().zip(&names).map(|(r, n)| (r, n.as_str())).collect();
    let (joint, each) = calibrate_shared(&pairs, &name(&s_path), &job.spec()?, progress)?;
    let stem = job.out_dir()?.join(format!("operating_point_{}", job.braille));
    let mut md = markdown(&joint);
    for (arch, c) in archs.iter().zip(&each) {
        md += &format!("\n## {arch} alone ({})\n\n", c.classifier);
        md += markdown(c).split_once("\n\n").map_or("", |(_, body)| body);
    }
    let written = Written { joint: &joint, each: &each };
    conclude(job, s_path, joint.chosen.clone(), " (both architectures)", stem, &md, &written)
}

/// The table as `stem`.md and `written` as `stem`.json and, with `write`, the point recorded in
/// `segmenter`.
fn conclude(
    job: &CalibrateJob,
    segmenter: PathBuf,
    chosen: OperatingPoint,
    whose: &'static str,
    stem: PathBuf,
    md: &str,
    written: &impl serde::Serialize,
) -> Result<Calibrated> {
    let io = |path: PathBuf| move |source| Error::Io { path, source };
    if let Some(out) = stem.parent() {
        std::fs::create_dir_all(out).map_err(io(out.to_path_buf()))?;
    }
    std::fs::write(stem.with_extension("md"), md).map_err(io(stem.with_extension("md")))?;
    crate::write_json(&stem.with_extension("json"), written, true)?;
    if job.write {
        super::record(&segmenter, &chosen)?;
    }
    Ok(Calibrated { segmenter, chosen, whose, stem, written: job.write })
}

/// The line a calibration prints: the point chosen, its scores, and where the grid is.
impl std::fmt::Display for Calibrated {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (p, c) = (&self.chosen, self.chosen.calibration.as_ref());
        writeln!(
            f,
            "chosen for {}{}: threshold {}, {} frames (mean word accuracy {:.3} without spelling, {:.3} with the lexicon); {}.md",
            self.segmenter.display(),
            self.whose,
            p.present_threshold,
            p.min_frames,
            c.map_or(f64::NAN, |c| c.mean_word_accuracy_none),
            c.map_or(f64::NAN, |c| c.mean_word_accuracy_lexicon),
            self.stem.display()
        )?;
        if let Some(a) = &p.abstain {
            writeln!(f, "abstains under a lexicon score of {} a letter", a.min_score_per_char)?;
        }
        if self.written {
            let (t, m) = (p.present_threshold, p.min_frames);
            writeln!(f, "recorded in {}: threshold {t}, {m} frames", self.segmenter.display())?;
        }
        Ok(())
    }
}
