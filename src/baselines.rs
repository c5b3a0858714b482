//! `braille baselines`: the non-spiking floors of a tactile dataset folder, on the SNN search's
//! validation hold-out (`experiments::train::baselines`).

use anyhow::Result;
use encoders::dataset::Dataset;
use experiments::train::fit::{EvalTest, TactileData};
use experiments::train::search::{DataProfile, derived_recipe};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A dataset folder in the iCub Braille layout (any channel and class count).
    #[arg(long)]
    data: PathBuf,
    /// Sampling period of analog data, in microseconds.
    #[arg(long, default_value_t = 25_000)]
    period_us: i64,
    /// Share of the training split held out to choose each model's settings.
    #[arg(long, default_value_t = 0.2)]
    val_fraction: f64,
    #[arg(long, default_value_t = 1)]
    val_seed: u64,
    /// Score the test split (by default it is not looked at).
    #[arg(long)]
    eval_test: bool,
    /// JSON instead of a Markdown table.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<()> {
    let dataset = Dataset::load(&a.data, a.period_us)?;
    let profile = DataProfile::of(&dataset)?;
    // the events as the derived SNN recipe encodes them (its step and sigma-delta threshold)
    let data = TactileData::encode(&dataset, &derived_recipe(&profile))?;
    let eval_test = if a.eval_test { EvalTest::Yes } else { EvalTest::No };
    let rows = experiments::train::baselines::baselines(&data, a.val_fraction, a.val_seed, eval_test)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&serde_json::json!({ "profile": profile, "baselines": rows }))?);
    } else {
        println!("{}", experiments::train::baselines::markdown(&rows));
    }
    Ok(())
}
