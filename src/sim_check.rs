//! `braille sim-check`: the simulator's physics checks on fresh scans.

use anyhow::Result;

#[derive(clap::Args)]
pub struct Args {
    /// Boards (each with its own tolerances) averaged for the depth measurement.
    #[arg(long, default_value_t = 8)]
    trials: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let r = sim::checks::run(args.trials.max(1))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print!("{}", r.markdown());
    }
    Ok(())
}
