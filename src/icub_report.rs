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
    /// Folder holding `snn-raw1350.safetensors` and `snn-th10.safetensors` [default: the shipped
    /// ones, `models/icub/`].
    #[arg(long)]
    models: Option<PathBuf>,
    /// Folder holding the search's final models (`raw1350-warmup.safetensors`,
    /// `raw1350-warmup.seed2.safetensors`, ...), whose seed mean heads the table [default: the
    /// shipped ones, `models/search/`].
    #[arg(long)]
    search: Option<PathBuf>,
    /// Where to write `icub.md`, `icub.json` and `icub.png`.
    #[arg(long, default_value = "docs/results")]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let models = args.models.unwrap_or_else(|| crate::common::shipped().icub_dir(pipeline::shipped::Variant::Trained));
    let search = args.search.unwrap_or_else(|| crate::common::shipped().search_dir());
    let md = experiments::reports::figures::write_icub_report(&args.data, &models, Some(&search), &args.out)?;
    print!("{md}");
    Ok(())
}
