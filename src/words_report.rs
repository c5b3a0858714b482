//! `braille words-report`: the paper's speed table on SIMULATED EV scans for both architectures,
//! with and without spelling (Markdown, JSON and a plot).

use crate::common::Bar;
use anyhow::Result;
use experiments::reports::words::{WordsReportSpec, words_report};
use pipeline::reader::TimingMode;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Where to write `words.md`, `words.json` and `words_speed.png` [default:
    /// docs/results/REALISM/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// The folder of the reading models (`snn-segment`, `snn-words`, `resnet-tiny-segment`,
    /// `resnet-lite-normaug-words`) [default: those trained at `--realism`, `models/REALISM/`
    /// (`REALISM=nominal bash scripts/words.sh`)].
    #[arg(long)]
    models: Option<PathBuf>,
    /// EV scans per row and speed (the paper: 30).
    #[arg(long, default_value_t = 30)]
    trials: u64,
    /// Speeds of the arm, mm/s.
    #[arg(long, value_delimiter = ',', default_value = "8,16,24,32,48,64")]
    speeds: Vec<f64>,
    /// Mean speeds of hand-held scans, mm/s (none: `--hand-speeds` with no value).
    #[arg(long, value_delimiter = ',', num_args = 0.., default_value = "16,32")]
    hand_speeds: Vec<f64>,
    /// How far a hand-held scan's speed swings around its mean (relative amplitude).
    #[arg(long, default_value_t = 0.4)]
    hand_variation: f64,
    /// Where the reader's speed comes from; every timing reads the same scans.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "estimated,paper,given")]
    timings: Vec<TimingMode>,
    /// Rows of a text board of words no training row used, read at the arm's speeds (0: none).
    #[arg(long, default_value_t = 4)]
    unseen_rows: usize,
    /// Scans per row of the unseen words.
    #[arg(long, default_value_t = 10)]
    unseen_trials: u64,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    #[arg(long, default_value_t = corpus::world::TEST_SEED)]
    seed: u64,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

pub fn run(args: Args) -> Result<()> {
    let models = args.models.clone().unwrap_or_else(|| args.realism.models_dir());
    let world = args.realism.test_world();
    let spec = WordsReportSpec {
        speeds_mm_s: args.speeds,
        hand_speeds_mm_s: args.hand_speeds,
        hand_speed_variation: args.hand_variation,
        timings: args.timings,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        world,
        unseen_rows: args.unseen_rows,
        unseen_trials: args.unseen_trials,
    };
    let r = words_report(&models, &spec, &Bar::default())?;
    let out = args.out.clone().unwrap_or_else(|| args.realism.results_dir());
    experiments::reports::figures::write_words_report(&r, &out)?;
    eprintln!("wrote {}/words.md, words.json, words_speed.png", out.display());
    Ok(())
}
