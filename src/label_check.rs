//! `braille sim labels`: the paper's labeling pipeline against the simulator's ground truth on
//! fresh simulated scans.

use anyhow::Result;

#[derive(clap::Args)]
pub struct Args {
    /// Scans per board row and condition (the test sets': 30).
    #[arg(long, default_value_t = 30)]
    trials: u64,
    /// Scan seed (the test sets': with it and the test trials these are the very scans Table I
    /// scores). With `--boards validation`, the validation seed unless given.
    #[arg(long)]
    seed: Option<u64>,
    /// The boards scanned: the test boards (RAB, EV), or the validation boards in their place (VAL,
    /// VAL-WORDS) with the training sensor builds, where the labeler's settings are chosen.
    #[arg(long, value_enum, default_value_t = experiments::eval::labeling::CheckBoards::Test)]
    boards: experiments::eval::labeling::CheckBoards,
    #[command(flatten)]
    realism: crate::common::RealismArg,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    use experiments::eval::labeling::CheckBoards;
    let (seed, builds) = match args.boards {
        CheckBoards::Test => (corpus::world::TEST_SEED, crate::common::SensorBuilds::Test),
        CheckBoards::Validation => (corpus::world::VALIDATION_SEED, crate::common::SensorBuilds::Training),
    };
    let world = args.realism.world(builds);
    let rows = experiments::eval::labeling::label_check(args.trials, args.seed.unwrap_or(seed), &world, args.boards)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    print!("{}", experiments::eval::labeling::label_check_markdown(&rows));
    Ok(())
}
