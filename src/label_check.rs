//! `braille label-check`: the paper's labeling pipeline against the simulator's ground truth on
//! fresh simulated scans.

use anyhow::Result;

#[derive(clap::Args)]
pub struct Args {
    /// Scans per board row and condition.
    #[arg(long, default_value_t = 4)]
    trials: u64,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let rows = experiments::labeling::label_check(args.trials, args.seed)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    print!("{}", experiments::labeling::label_check_markdown(&rows));
    Ok(())
}
