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
    println!("Labeling pipeline against ground truth (SIMULATED scans, virtual Evetac):\n");
    println!(
        "| board | speed (mm/s) | depth (mm) | scans | count matched | windows right |\n| --- | --- | --- | --- | --- | --- |"
    );
    for r in &rows {
        println!(
            "| {} | {} | {} | {} | {}/{} | {}/{} ({:.1}%) |",
            r.board,
            r.speed_mm_s,
            r.depth_mm,
            r.scans,
            r.count_matched,
            r.scans,
            r.correct,
            r.characters,
            100.0 * r.accuracy
        );
    }
    Ok(())
}
