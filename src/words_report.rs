//! `braille words-report`: the paper's speed table on SIMULATED EV scans for both architectures,
//! with and without spelling (Markdown, JSON and a plot).

use crate::common::Bar;
use anyhow::Result;
use experiments::reports::words::words_report;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Where to write `words.md`, `words.json` and `words_speed.png`.
    #[arg(long, default_value = "docs/results")]
    out: PathBuf,
    /// EV scans per row and speed (the paper: 30).
    #[arg(long, default_value_t = 30)]
    trials: u64,
    #[arg(long, value_delimiter = ',', default_value = "8,16,24,32")]
    speeds: Vec<f64>,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    #[arg(long, default_value_t = 1_000_003)]
    seed: u64,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

pub fn run(args: Args) -> Result<()> {
    let models = crate::common::repo_path("models");
    let world = args.realism.test_world();
    let r = words_report(&models, &args.speeds, args.depth, args.trials, args.seed, &world, &Bar::default())?;
    crate::charts::write_words_report(&r, &args.out)
}
