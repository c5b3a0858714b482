//! `braille sim check`: the simulator's physics checks on fresh scans, at a realism preset.

use anyhow::Result;
use sim::Realism;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Boards (each with its own tolerances) averaged for the depth measurement.
    #[arg(long, default_value_t = 8)]
    trials: u64,
    /// The simulator's nuisances (docs/simulator.md).
    #[arg(long, value_enum, default_value_t = Realism::Nominal)]
    realism: Realism,
    /// Also draw one dot's events against its position at 8 and 32 mm/s, with and without the
    /// gel's dynamics (PNG).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let r = sim::checks::run(args.realism, args.trials.max(1))?;
    if let Some(path) = &args.plot {
        experiments::reports::figures::dot_lag_figure(&r, path)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print!("{}", r.markdown());
    }
    Ok(())
}
