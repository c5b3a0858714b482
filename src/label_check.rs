//! `braille label-check`: the paper's labeling pipeline against the simulator's ground truth on
//! fresh simulated scans.

use anyhow::Result;

#[derive(clap::Args)]
pub struct Args {
    /// Scans per board row and condition (the test sets': 30).
    #[arg(long, default_value_t = 30)]
    trials: u64,
    /// Scan seed (the test sets': with it and the test trials these are the very scans Table I
    /// scores).
    #[arg(long, default_value_t = 1_000_003)]
    seed: u64,
    #[command(flatten)]
    realism: crate::common::RealismArg,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let rows = experiments::labeling::label_check(args.trials, args.seed, &args.realism.test_world())?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    print!("{}", experiments::labeling::label_check_markdown(&rows));
    Ok(())
}
