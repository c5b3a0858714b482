//! `braille report`: every results table and figure regenerated into one folder, with an index
//! ([`experiments::reports::all`]).

use crate::common::{Bar, repo_path};
use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The report's folder (Markdown, JSON, PNG).
    #[arg(long, default_value = "report")]
    out: PathBuf,
    /// Small trial counts: the same report in a few minutes, for checking that it runs (its
    /// figures are too noisy to quote).
    #[arg(long)]
    quick: bool,
    /// The world of the model tables (Table I, the speed table); the physics checks run at
    /// `nominal` whatever this says.
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

pub fn run(args: Args) -> Result<()> {
    let spec = experiments::reports::all::ReportSpec {
        out: args.out,
        quick: args.quick,
        realism: args.realism.realism,
        models: crate::common::shipped(),
        icub: repo_path("data/icub_braille"),
        search_logs: repo_path("docs/results/search"),
    };
    Ok(experiments::reports::all::run(&spec, &Bar::default())?)
}
