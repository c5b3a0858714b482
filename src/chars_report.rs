//! `braille report chars`: the paper's Table I (Raw / Norm / Aug / NormAug) and its depth figure
//! on SIMULATED scans of the RAB board at 8 mm/s, with the SNN beside the ResNet on the same
//! windows, and confusion matrices. Markdown, JSON and PNG.

use crate::common::Bar;
use anyhow::Result;
use experiments::reports::chars::chars_report;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Folder holding `resnet-lite-{raw,norm,aug,normaug}.safetensors` and `snn-chars.safetensors`
    /// (`scripts/table1.sh`), and the `+ words` models (`scripts/words.sh`); missing models are
    /// left out [default: those trained at `--realism`, `models/REALISM/`].
    #[arg(long)]
    models: Option<PathBuf>,
    /// Where to write `chars.md`, `chars.json`, `chars_depth.png` and the confusion PNGs
    /// [default: docs/results/REALISM/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// RAB scans per board row and depth. 30 (about 720 windows a depth): the same model scored
    /// 97.9% and 99.1% at 1.5 mm on two sets of 10 scans, too coarse for a 1.5-point comparison.
    #[arg(long, default_value_t = 30)]
    trials: u64,
    /// Scan seed of the test scans (training used others).
    #[arg(long, default_value_t = corpus::world::TEST_SEED)]
    seed: u64,
    /// Depths to test, in mm [default: the paper's 0.2-1.5 mm].
    #[arg(long, value_delimiter = ',')]
    depths: Vec<f64>,
    /// The sensor builds that scan RAB: `test` (builds no model was trained on, the headline) or
    /// `training` (the builds the training scans came from, on RAB, which no training scan shows:
    /// the paper's protocol, which tested with the sensor it trained on) or `validation` (builds
    /// held out of training and test).
    #[arg(long, value_enum, default_value_t = crate::common::SensorBuilds::Test)]
    sensor_builds: crate::common::SensorBuilds,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

pub fn run(args: Args) -> Result<()> {
    let models = args.models.clone().unwrap_or_else(|| args.realism.models_dir());
    let report = chars_report(
        &models,
        &args.depths,
        args.trials,
        args.seed,
        &args.realism.world(args.sensor_builds),
        &Bar::default(),
    )?;
    let md = experiments::reports::figures::write_chars_report(
        &report,
        &args.out.clone().unwrap_or_else(|| args.realism.results_dir()),
    )?;
    print!("{md}");
    Ok(())
}
