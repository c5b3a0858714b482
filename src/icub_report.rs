//! `braille icub-report`: the shipped SNNs on the real iCub Braille recordings (fixed test
//! splits), run by the event-driven engine, beside the published and measured baselines; a
//! Markdown table and a bar chart.

use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Folder holding the dataset folders `raw1350` and `th10`.
    #[arg(long, default_value = "data/icub_braille")]
    data: PathBuf,
    /// Folder holding `snn-raw1350.safetensors` and `snn-th10.safetensors`.
    #[arg(long, default_value = "models")]
    models: PathBuf,
    /// Where to write `icub.md`, `icub.json` and `icub.png`.
    #[arg(long, default_value = "docs/results")]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let md = crate::charts::write_icub_report(&args.data, &args.models, &args.out)?;
    print!("{md}");
    Ok(())
}
