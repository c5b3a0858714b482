//! Table I, the word and the letter reports as their commands ask for them (`braille report
//! chars|words|letters`; with the `clap` feature, their arguments): the defaults of each code and
//! board, the development or the sealed test set (`--final`), the report computed, and its files
//! written.

use crate::eval::chars::CharModel;
use crate::reports::letters::{LettersReportSpec, letters_report};
use crate::reports::ueb::{UebReportSpec, ueb_report};
use crate::reports::words::{WordsReportSpec, words_report};
use crate::{Error, Progress, Result};
use corpus::boards::HeldOut;
use corpus::world::{SensorBuilds, World};
use pipeline::classify::ReaderModels;
use pipeline::code::BrailleCode;
use pipeline::reader::TimingMode;
use pipeline::shipped::ReaderFiles;
use sim::Realism;
use snn::model_file::Arch;
use std::path::PathBuf;

/// Where a report's models come from and where it writes: `models/REALISM/` and
/// `docs/results/REALISM/` unless given.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct ReportPlace {
    /// The simulator's nuisances of the scans and of the default models (docs/simulator.md).
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = Realism::Nominal))]
    pub realism: Realism,
    /// The folder of the reading models [default: those trained at `--realism`, `models/REALISM/`].
    #[cfg_attr(feature = "clap", arg(long))]
    pub models: Option<PathBuf>,
    /// Where to write the report's files [default: docs/results/REALISM/, or its `sealed/` with
    /// `--final`].
    #[cfg_attr(feature = "clap", arg(long))]
    pub out: Option<PathBuf>,
    /// Read the sealed test set instead of the development one (the test boards printed anew,
    /// sensor builds and scans no run has read; `crate::sealed`); the caller records the read.
    #[cfg_attr(feature = "clap", arg(long = "final", conflicts_with = "seed"))]
    pub final_read: bool,
    /// --final: the protocol file whose ledger records the read [default: docs/protocol.md].
    #[cfg_attr(feature = "clap", arg(long, requires = "final_read"))]
    pub ledger: Option<PathBuf>,
}

impl ReportPlace {
    /// The world and scan seed of the test scans: the sealed set's with `final_read` (its scans
    /// drawn from `SEALED_SEED`), else `builds` at the preset with `seed`.
    fn test_world(&self, builds: SensorBuilds, seed: u64) -> (World, u64) {
        self.test_world_sealed_at(builds, seed, corpus::world::SEALED_SEED)
    }

    /// [`Self::test_world`] with the sealed scans drawn from `sealed_seed`.
    fn test_world_sealed_at(&self, builds: SensorBuilds, seed: u64, sealed_seed: u64) -> (World, u64) {
        match self.final_read {
            true => (World::sealed(self.realism), sealed_seed),
            false => (World::of(self.realism, builds), seed),
        }
    }

    /// The sealed set a report reads with `final_read`, as the ledger names it.
    fn sealed_set(&self, what: &str) -> String {
        format!("{what}, {}", self.realism)
    }

    /// What a job wrote, naming the sealed set it read with `final_read`, scanned in `world`
    /// with `seed`.
    fn written(&self, printed: String, md: PathBuf, set: &str, (world, seed): (&World, u64)) -> Written {
        let sealed_set = self.final_read.then(|| self.sealed_set(set));
        let sealed_scans = (world.sensors.clone(), seed);
        Written { printed, md, sealed_set, sealed_scans, ledger: self.ledger.clone() }
    }

    pub(crate) fn models(&self) -> Result<&PathBuf> {
        self.models.as_ref().ok_or_else(|| Error::Options("no models folder (`models`)".into()))
    }

    pub(crate) fn out(&self) -> Result<&PathBuf> {
        self.out.as_ref().ok_or_else(|| Error::Options("no folder for the report (`out`)".into()))
    }
}

/// What a report job wrote: the text it prints, its Markdown file, and with `--final` the sealed
/// set it read (as the ledger names it; the caller records the read with [`crate::sealed`]).
#[derive(Debug, Clone)]
pub struct Written {
    pub printed: String,
    pub md: PathBuf,
    pub sealed_set: Option<String>,
    /// With `sealed_set`: the sensor builds and the scan seed it read.
    pub sealed_scans: (Vec<u64>, u64),
    /// With `sealed_set`: the protocol file whose ledger records the read.
    pub ledger: Option<PathBuf>,
}

/// The paper's Table I and its depth curve on SIMULATED RAB scans: the ResNet's four input
/// configurations, the paper's ResNet-34, the SNN and the `+ words` classifiers on the same
/// windows.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct CharsReportJob {
    #[cfg_attr(feature = "clap", command(flatten))]
    pub place: ReportPlace,
    /// RAB scans per board row and depth. 30 (about 720 windows a depth): the same model scored
    /// 97.9% and 99.1% at 1.5 mm on two sets of 10 scans, too coarse for a 1.5-point comparison.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 30))]
    pub trials: u64,
    /// Scan seed of the test scans (training used others).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = corpus::world::TEST_SEED))]
    pub seed: u64,
    /// Depths to test, in mm [default: the paper's 0.2-1.5 mm].
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ','))]
    pub depths: Vec<f64>,
    /// The sensor builds that scan RAB: `test` (builds no model was trained on, the headline) or
    /// `training` (the builds the training scans came from, on RAB, which no training scan shows:
    /// the paper's protocol, which tested with the sensor it trained on) or `validation` (builds
    /// held out of training and test).
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value_t = SensorBuilds::Test, conflicts_with = "final_read"))]
    pub sensor_builds: SensorBuilds,
}

/// Computes Table I and writes its files (`chars.md`, `chars.json`, the figures).
pub fn chars(job: &CharsReportJob, progress: &dyn Progress) -> Result<Written> {
    let (models, out) = (job.place.models()?, job.place.out()?);
    let (world, seed) = job.place.test_world(job.sensor_builds, job.seed);
    let report = crate::reports::chars::chars_report(models, &job.depths, job.trials, seed, &world, progress)?;
    let md = crate::reports::figures::write_chars_report(&report, out)?;
    Ok(job.place.written(md, out.join("chars.md"), "Table I (RAB)", (&world, seed)))
}

/// The paper's speed table on SIMULATED EV scans for both architectures, with and without
/// spelling; in UEB, the cell readers' cells and contracted sentences against speed.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct WordsReportJob {
    #[cfg_attr(feature = "clap", command(flatten))]
    pub place: ReportPlace,
    /// Scans per row and speed [default: 30, the paper's, on EV; 3 on the UEB sentences].
    #[cfg_attr(feature = "clap", arg(long))]
    pub trials: Option<u64>,
    /// Speeds of the arm, mm/s [default: 8,16,24,32,48,64; 8,16,32 in UEB].
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ','))]
    pub speeds: Option<Vec<f64>>,
    /// The Braille code: `grade1-letters` (the paper's speed table on EV), or `ueb-g1`/`ueb-g2`:
    /// the cell readers of models/REALISM/ueb/ on every cell of RCB (`--cell-trials` scans a
    /// row at 8 mm/s, 1.5 mm) and on UEB-SENTENCES at `--speeds` (`ueb.md`, `ueb.json`,
    /// `ueb_speed.png` in `--out`/ueb/).
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "grade1-letters"))]
    pub braille: BrailleCode,
    /// UEB: scans per row of the cell board.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 30))]
    pub cell_trials: u64,
    /// UEB: the readers keep the classifier's column for cells of one dot column (no cell grid,
    /// `pipeline::grid`), to measure what the grid does.
    #[cfg_attr(feature = "clap", arg(long))]
    pub no_cell_grid: bool,
    /// UEB: the validation boards (VCB, VAL-UEB) scanned by the training builds, for choices,
    /// in place of the test boards.
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "final_read"))]
    pub validation: bool,
    /// Mean speeds of hand-held scans, mm/s (none: `--hand-speeds` with no value).
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ',', num_args = 0.., default_value = "16,32"))]
    pub hand_speeds: Vec<f64>,
    /// How far a hand-held scan's speed swings around its mean (relative amplitude).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 0.4))]
    pub hand_variation: f64,
    /// Where the reader's speed comes from; every timing reads the same scans [default:
    /// estimated,paper,given; estimated in UEB, which reads with one].
    #[cfg_attr(feature = "clap", arg(long, value_enum, value_delimiter = ','))]
    pub timings: Option<Vec<TimingMode>>,
    /// Rows of a text board of words no training row used, read at the arm's speeds (0: none).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 4))]
    pub unseen_rows: usize,
    /// Scans per row of the unseen words.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 10))]
    pub unseen_trials: u64,
    /// The scans' depth, mm [default: 1.5 on EV, 1.0 on the UEB sentences].
    #[cfg_attr(feature = "clap", arg(long))]
    pub depth: Option<f64>,
    #[cfg_attr(feature = "clap", arg(long, default_value_t = corpus::world::TEST_SEED))]
    pub seed: u64,
}

/// Computes the report and writes its files; what it prints back is, in UEB, its Markdown.
pub fn words(job: &WordsReportJob, progress: &dyn Progress) -> Result<Written> {
    let (models, out) = (job.place.models()?, job.place.out()?);
    if job.braille != BrailleCode::Grade1Letters {
        let (held_out, builds) = if job.validation {
            (HeldOut::Validation, SensorBuilds::Training)
        } else {
            (HeldOut::Test, SensorBuilds::Test)
        };
        let timings = job.timings.clone().unwrap_or_else(|| vec![TimingMode::Estimated]);
        let [timing] = timings[..] else {
            return Err(Error::Options(format!(
                "--braille {}: one --timings (the UEB report reads with one)",
                job.braille
            )));
        };
        let (world, seed) = job.place.test_world(builds, job.seed);
        let spec = UebReportSpec {
            code: job.braille,
            held_out,
            cell_speed_mm_s: 8.0,
            cell_depth_mm: 1.5,
            cell_trials: job.cell_trials,
            speeds_mm_s: job.speeds.clone().unwrap_or_else(|| vec![8.0, 16.0, 32.0]),
            depth_mm: job.depth.unwrap_or(1.0),
            trials: job.trials.unwrap_or(3),
            timing,
            cell_grid: !job.no_cell_grid,
            seed,
            world,
        };
        let r = ueb_report(models, &spec, progress)?;
        let out = out.join("ueb");
        crate::reports::figures::write_ueb_report(&r, &out)?;
        let set = "UEB (RCB, UEB-SENTENCES)";
        let md = crate::reports::ueb::markdown(&r);
        return Ok(job.place.written(md, out.join("ueb.md"), set, (&spec.world, spec.seed)));
    }
    let (world, seed) = job.place.test_world(SensorBuilds::Test, job.seed);
    let spec = WordsReportSpec {
        speeds_mm_s: job.speeds.clone().unwrap_or_else(|| vec![8.0, 16.0, 24.0, 32.0, 48.0, 64.0]),
        hand_speeds_mm_s: job.hand_speeds.clone(),
        hand_speed_variation: job.hand_variation,
        timings: job
            .timings
            .clone()
            .unwrap_or_else(|| vec![TimingMode::Estimated, TimingMode::Paper, TimingMode::Given]),
        depth_mm: job.depth.unwrap_or(1.5),
        trials: job.trials.unwrap_or(30),
        seed,
        world,
        unseen_rows: job.unseen_rows,
        unseen_trials: job.unseen_trials,
    };
    let r = words_report(models, &spec, progress)?;
    crate::reports::figures::write_words_report(&r, out)?;
    let set = "words (EV, unseen words)";
    Ok(job.place.written(String::new(), out.join("words.md"), set, (&spec.world, spec.seed)))
}

/// Every letter at every place in a row, read by both architectures from SIMULATED scans of the
/// all-letters board over speed and depth.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct LettersReportJob {
    #[cfg_attr(feature = "clap", command(flatten))]
    pub place: ReportPlace,
    /// The validation board `VAL-LETTERS` with the training sensor builds and the validation seed,
    /// for choices, in place of the test board `ALL-LETTERS` with the test builds and seed
    /// (`val_letters.*` in place of `letters.*`).
    #[cfg_attr(feature = "clap", arg(long, conflicts_with = "final_read"))]
    pub validation: bool,
    /// With `--validation`: the sensor builds that scan it, `training` (the default) or
    /// `validation` (builds held out of training and test, as the test builds are: for choices
    /// that must hold on a sensor never trained on). The test builds are the test board's only.
    #[cfg_attr(feature = "clap", arg(long, value_enum, requires = "validation"))]
    pub sensor_builds: Option<SensorBuilds>,
    /// Read with this SNN classifier in place of the shipped one (a candidate).
    #[cfg_attr(feature = "clap", arg(long))]
    pub snn_classifier: Option<PathBuf>,
    /// Read with this SNN segmentation network in place of the shipped one.
    #[cfg_attr(feature = "clap", arg(long))]
    pub snn_segmenter: Option<PathBuf>,
    /// Which architectures read.
    #[cfg_attr(feature = "clap", arg(long, value_enum, value_delimiter = ',', default_value = "resnet,snn"))]
    pub archs: Vec<Arch>,
    /// Speeds of the arm, mm/s.
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ',', default_value = "8,16,24,32,48"))]
    pub speeds: Vec<f64>,
    /// Depths, mm.
    #[cfg_attr(feature = "clap", arg(long, value_delimiter = ',', default_value = "0.6,1.0,1.5"))]
    pub depths: Vec<f64>,
    /// Scans per row at each condition.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1))]
    pub trials: u64,
    /// The per-letter tables' condition, read with `--focus-trials` scans per row.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 16.0))]
    pub focus_speed: f64,
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1.0))]
    pub focus_depth: f64,
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 4))]
    pub focus_trials: u64,
    /// Read only the board's first rows (a quick check, labelled as such).
    #[cfg_attr(feature = "clap", arg(long))]
    pub rows: Option<usize>,
    /// Scan seed [default: the test seed, or the validation seed with `--validation`].
    #[cfg_attr(feature = "clap", arg(long))]
    pub seed: Option<u64>,
}

/// Computes the report and writes it; what it prints back is the lines of its targets.
pub fn letters(job: &LettersReportJob, progress: &dyn Progress) -> Result<Written> {
    let (models, out) = (job.place.models()?, job.place.out()?);
    let (held_out, builds, seed) = if job.validation && !job.place.final_read {
        let builds = job.sensor_builds.unwrap_or(SensorBuilds::Training);
        if builds == SensorBuilds::Test {
            return Err(Error::Options(
                "--sensor-builds test: the test builds read the test board only (choices are made on training or validation builds)".into(),
            ));
        }
        (HeldOut::Validation, builds, corpus::world::VALIDATION_SEED)
    } else {
        (HeldOut::Test, SensorBuilds::Test, corpus::world::TEST_SEED)
    };
    let readers: Vec<ReaderFiles> = job
        .archs
        .iter()
        .map(|&arch| {
            let mut f = pipeline::shipped::reader_in(models, arch);
            if arch == Arch::Snn {
                f.classifier = job.snn_classifier.clone().unwrap_or(f.classifier);
                f.segmenter = job.snn_segmenter.clone().unwrap_or(f.segmenter);
            }
            f
        })
        .collect();
    let (world, seed) = job.place.test_world(builds, job.seed.unwrap_or(seed));
    let spec = LettersReportSpec {
        held_out,
        speeds_mm_s: job.speeds.clone(),
        depths_mm: job.depths.clone(),
        trials: job.trials,
        focus_speed_mm_s: job.focus_speed,
        focus_depth_mm: job.focus_depth,
        focus_trials: job.focus_trials,
        seed,
        world,
        first_rows: job.rows,
    };
    let r = letters_report(&readers, &spec, progress)?;
    let md = crate::reports::figures::write_letters_report(&r, out)?;
    let targets: String = crate::reports::letters::targets(&r).iter().map(|l| format!("{l}\n")).collect();
    Ok(job.place.written(targets, md, "letters (ALL-LETTERS)", (&spec.world, spec.seed)))
}

/// Each architecture's shipped character classifier against one nuisance of the virtual Evetac
/// at a time (`crate::eval::robustness`), on the test builds or, with `--final`, the sealed set;
/// with `words`, each architecture's whole reader on a board's words
/// (`crate::eval::robustness_words`).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct RobustnessReportJob {
    #[cfg_attr(feature = "clap", command(flatten))]
    pub place: ReportPlace,
    /// Nuisances to sweep [default: all].
    #[cfg_attr(feature = "clap", arg(long, value_enum, value_delimiter = ','))]
    pub nuisances: Vec<crate::eval::robustness::Nuisance>,
    /// Carry the sweep to words: each architecture's reader pair (from the models folder) reads
    /// the board's words, speed estimated, 1 - WER without spelling and with the lexicon, and
    /// each one's cliff (writes `robustness_words.md` and `.json`).
    #[cfg_attr(feature = "clap", arg(long))]
    pub words: bool,
    /// The sensor builds that scan (`validation`, with a validation board, for choices); not
    /// with `--final`, which scans with the sealed set's.
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "test", conflicts_with = "final_read"))]
    pub sensor_builds: SensorBuilds,
    /// Board scanned, as `eval` names boards (`VAL-WORDS` too) [default: the paper's test board
    /// RAB; EV with `--words`].
    #[cfg_attr(feature = "clap", arg(long, value_parser = corpus::boards::parse_board))]
    pub board: Option<sim::BoardKind>,
    /// Scans per board row and level.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 4))]
    pub trials: u64,
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 8.0))]
    pub speed: f64,
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 1.5))]
    pub depth: f64,
    /// Scan seed of the development read (training used others).
    #[cfg_attr(feature = "clap", arg(long, default_value_t = corpus::world::VALIDATION_SEED))]
    pub seed: u64,
}

impl RobustnessReportJob {
    /// What the job sweeps, on `board` unless it names one: the sealed world with `--final`.
    fn spec(&self, models_dir: &std::path::Path, board: sim::BoardKind) -> crate::eval::robustness::SweepSpec {
        use crate::eval::robustness::Nuisance;
        let (world, seed) =
            self.place.test_world_sealed_at(self.sensor_builds, self.seed, corpus::world::SEALED_SWEEP_SEED);
        crate::eval::robustness::SweepSpec {
            base: self.place.realism,
            nuisances: if self.nuisances.is_empty() { Nuisance::ALL.to_vec() } else { self.nuisances.clone() },
            board: self.board.clone().unwrap_or(board),
            speed_mm_s: self.speed,
            depth_mm: self.depth,
            trials: self.trials,
            seed,
            world,
            models_dir: models_dir.display().to_string(),
        }
    }
}

/// Sweeps every nuisance of `job` and writes `robustness.md`, `.json` and a PNG per nuisance.
pub fn robustness(job: &RobustnessReportJob, progress: &dyn Progress) -> Result<Written> {
    use crate::eval::robustness::sweep;
    if job.words {
        return robustness_words(job, progress);
    }
    let (models_dir, out) = (job.place.models()?, job.place.out()?);
    let mut models = Vec::new();
    for (name, arch) in [("ResNet lite NormAug", Arch::Resnet), ("SNN", Arch::Snn)] {
        models.push((name.to_string(), CharModel::load(&pipeline::shipped::chars_in(models_dir, arch))?));
    }
    let spec = job.spec(models_dir, sim::BoardKind::Rab);
    let board = spec.board.clone();
    let refs: Vec<(String, &CharModel)> = models.iter().map(|(n, m)| (n.clone(), m)).collect();
    let report = sweep(&spec, &refs, progress)?;
    let printed = crate::reports::figures::write_robustness_report(&report, out)?;
    let set = format!("robustness ({})", board.name());
    Ok(job.place.written(printed, out.join("robustness.md"), &set, (&spec.world, spec.seed)))
}

/// [`robustness`] carried to words: each architecture's reader pair from the models folder.
fn robustness_words(job: &RobustnessReportJob, progress: &dyn Progress) -> Result<Written> {
    use crate::eval::robustness_words::{markdown_words, sweep_words};
    if job.place.final_read {
        return Err(Error::Options(
            "the words sweep has no sealed set yet: one is fixed, with its rule, in docs/protocol.md before it is read"
                .into(),
        ));
    }
    let (models_dir, out) = (job.place.models()?, job.place.out()?);
    let mut readers = Vec::new();
    for (name, arch) in [("ResNet", Arch::Resnet), ("SNN", Arch::Snn)] {
        let files = pipeline::shipped::reader_for(models_dir, arch, pipeline::code::BrailleCode::Grade1Letters);
        let r = ReaderModels::load(&files.segmenter, &files.classifier, pipeline::classify::SnnRunner::Sliding)?;
        readers.push((name.to_string(), r));
    }
    let spec = job.spec(models_dir, sim::BoardKind::Ev);
    let board = spec.board.clone();
    let refs: Vec<(String, &ReaderModels)> = readers.iter().map(|(n, r)| (n.clone(), r)).collect();
    let report = sweep_words(&spec, &refs, progress)?;
    std::fs::create_dir_all(out).map_err(|source| Error::Io { path: out.clone(), source })?;
    let command = format!(
        "braille sim robustness --words --realism {} --models {} --board '{}' --sensor-builds {}{} --trials {} --speed {} --depth {}{}{}",
        job.place.realism,
        models_dir.display(),
        corpus::boards::board_name(&board),
        format!("{:?}", job.sensor_builds).to_lowercase(),
        if job.place.final_read { String::new() } else { format!(" --seed {}", job.seed) },
        job.trials,
        job.speed,
        job.depth,
        if job.nuisances.is_empty() {
            String::new()
        } else {
            format!(
                " --nuisances {}",
                job.nuisances
                    .iter()
                    .map(|n| serde_json::to_string(n).unwrap_or_default().trim_matches('"').to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            )
        },
        if job.place.final_read { " --final" } else { "" }
    );
    let md_text = markdown_words(&report, &command);
    let md = out.join("robustness_words.md");
    std::fs::write(&md, &md_text).map_err(|source| Error::Io { path: md.clone(), source })?;
    crate::write_json(&out.join("robustness_words.json"), &report, true)?;
    let set = format!("robustness of words ({})", board.name());
    Ok(job.place.written(md_text, md, &set, (&spec.world, spec.seed)))
}
