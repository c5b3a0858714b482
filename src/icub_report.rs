//! `braille report icub`: the shipped SNNs on the real iCub Braille recordings (fixed test
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
    /// Folder holding the searches' final models (`raw1350-stepscale.safetensors`,
    /// `th10-warmup.safetensors`, `th10-warmup.seed2.safetensors`, `th10-exact.safetensors`,
    /// ...); the seed mean of the better on validation of a dataset's truncated and exact
    /// searches (the fixed rule's, `experiments::reports::tactile::SnnSearch::under_rule`) heads
    /// the table
    /// [default: the shipped ones, `models/search/`].
    #[arg(long)]
    search: Option<PathBuf>,
    /// Folder of the searches' trial logs, one folder per search run [default:
    /// `docs/results/search`].
    #[arg(long)]
    search_logs: Option<PathBuf>,
    /// Where to write `icub.md`, `icub.json` and `icub.png`.
    #[arg(long, default_value = "docs/results")]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let models = args.models.unwrap_or_else(|| crate::common::shipped().icub_dir(pipeline::shipped::Variant::Trained));
    let search = args.search.unwrap_or_else(|| crate::common::shipped().search_dir());
    let folders = experiments::reports::icub::SearchFolders {
        models: search,
        logs: args.search_logs.unwrap_or_else(|| crate::common::repo_path("docs/results/search")),
    };
    let md = experiments::reports::figures::write_icub_report(&args.data, &models, Some(&folders), &args.out)?;
    print!("{md}");
    Ok(())
}
