//! `braille report letters`: every letter at every place in a row, read by both architectures
//! from SIMULATED scans of the all-letters board over speed and depth (Markdown and JSON).

use crate::common::Bar;
use anyhow::{Result, bail};
use corpus::boards::HeldOut;
use experiments::reports::letters::{LettersReportSpec, letters_report};
use snn::model_file::Arch;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Where to write `letters.md` and `letters.json` (`val_letters.*` with `--validation`)
    /// [default: docs/results/REALISM/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// The folder of the reading models [default: those trained at `--realism`].
    #[arg(long)]
    models: Option<PathBuf>,
    /// The validation board `VAL-LETTERS` with the training sensor builds and the validation seed,
    /// for choices, in place of the test board `ALL-LETTERS` with the test builds and seed.
    #[arg(long)]
    validation: bool,
    /// With `--validation`: the sensor builds that scan it, `training` (the default) or
    /// `validation` (builds held out of training and test, as the test builds are: for choices
    /// that must hold on a sensor never trained on). The test builds are the test board's only.
    #[arg(long, value_enum, requires = "validation")]
    sensor_builds: Option<crate::common::SensorBuilds>,
    /// Read with this SNN classifier in place of the shipped one (a candidate).
    #[arg(long)]
    snn_classifier: Option<PathBuf>,
    /// Read with this SNN segmentation network in place of the shipped one.
    #[arg(long)]
    snn_segmenter: Option<PathBuf>,
    /// Which architectures read.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "resnet,snn")]
    archs: Vec<Arch>,
    /// Speeds of the arm, mm/s.
    #[arg(long, value_delimiter = ',', default_value = "8,16,24,32,48")]
    speeds: Vec<f64>,
    /// Depths, mm.
    #[arg(long, value_delimiter = ',', default_value = "0.6,1.0,1.5")]
    depths: Vec<f64>,
    /// Scans per row at each condition.
    #[arg(long, default_value_t = 1)]
    trials: u64,
    /// The per-letter tables' condition, read with `--focus-trials` scans per row.
    #[arg(long, default_value_t = 16.0)]
    focus_speed: f64,
    #[arg(long, default_value_t = 1.0)]
    focus_depth: f64,
    #[arg(long, default_value_t = 4)]
    focus_trials: u64,
    /// Read only the board's first rows (a quick check, labelled as such).
    #[arg(long)]
    rows: Option<usize>,
    /// Scan seed [default: the test seed, or the validation seed with `--validation`].
    #[arg(long)]
    seed: Option<u64>,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

pub fn run(args: Args) -> Result<()> {
    let models = args.models.clone().unwrap_or_else(|| args.realism.models_dir());
    let (held_out, builds, seed) = if args.validation {
        let builds = args.sensor_builds.unwrap_or(crate::common::SensorBuilds::Training);
        if builds == crate::common::SensorBuilds::Test {
            bail!(
                "--sensor-builds test: the test builds read the test board only (choices are made on training or validation builds)"
            );
        }
        (HeldOut::Validation, builds, corpus::world::VALIDATION_SEED)
    } else {
        (HeldOut::Test, crate::common::SensorBuilds::Test, corpus::world::TEST_SEED)
    };
    let readers: Vec<pipeline::shipped::ReaderFiles> = args
        .archs
        .iter()
        .map(|&arch| {
            let mut f = pipeline::shipped::reader_in(&models, arch);
            if arch == Arch::Snn {
                f.classifier = args.snn_classifier.clone().unwrap_or(f.classifier);
                f.segmenter = args.snn_segmenter.clone().unwrap_or(f.segmenter);
            }
            f
        })
        .collect();
    let spec = LettersReportSpec {
        held_out,
        speeds_mm_s: args.speeds,
        depths_mm: args.depths,
        trials: args.trials,
        focus_speed_mm_s: args.focus_speed,
        focus_depth_mm: args.focus_depth,
        focus_trials: args.focus_trials,
        seed: args.seed.unwrap_or(seed),
        world: args.realism.world(builds),
        first_rows: args.rows,
    };
    let r = letters_report(&readers, &spec, &Bar::default())?;
    for line in experiments::reports::letters::targets(&r) {
        println!("{line}");
    }
    let out = args.out.clone().unwrap_or_else(|| args.realism.results_dir());
    let md = experiments::reports::figures::write_letters_report(&r, &out)?;
    eprintln!("wrote {} and its JSON", md.display());
    Ok(())
}
