//! `braille report`: every results table and figure regenerated into one folder, with an index
//! ([`experiments::reports::all`]); `braille report KIND` one report alone.

use crate::common::{Bar, repo_path};
use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct Args {
    /// One report alone (without it: every table and figure).
    #[command(subcommand)]
    kind: Option<Kind>,
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

/// One report.
#[derive(clap::Subcommand)]
pub enum Kind {
    /// Table I and the depth curve on simulated RAB scans: the four ResNet configurations and the
    /// SNN on the same windows (Markdown, JSON, PNG).
    Chars(experiments::reports::jobs::CharsReportJob),
    /// The paper's speed table on SIMULATED EV scans: both architectures, 8-64 mm/s and hand-held,
    /// every timing, unseen words, with and without spelling (Markdown, JSON, PNG).
    Words(experiments::reports::jobs::WordsReportJob),
    /// Every letter at every place in a row: both architectures on SIMULATED scans of the
    /// all-letters board over speed and depth (Markdown, JSON).
    Letters(experiments::reports::jobs::LettersReportJob),
    /// Words across the envelope: both architectures' readers at each preset x speed (8-200
    /// mm/s) x depth, speed estimated, seed means over model folders (Markdown, JSON).
    Envelope(experiments::reports::envelope::EnvelopeReportJob),
    /// The shipped SNNs on the real iCub recordings beside the baselines (Markdown, JSON, PNG).
    Icub(crate::icub_report::Args),
    /// Per tactile dataset, the SNN search's models beside the GRU, LSTM, temporal CNN and linear
    /// floors chosen by the same protocol (Markdown, JSON).
    Tactile(crate::tactile_report::Args),
    /// What the faithful NIR export costs each shipped SNN, and every exportable model against
    /// Speck, Xylo, Loihi 2 and SpiNNaker 2 (Markdown, JSON).
    Chip(crate::chip_report::Args),
}

pub fn run(args: Args) -> Result<()> {
    match args.kind {
        Some(Kind::Chars(a)) => return crate::chars_report::run(a),
        Some(Kind::Words(a)) => return crate::words_report::run(a),
        Some(Kind::Letters(a)) => return crate::letters_report::run(a),
        Some(Kind::Envelope(mut a)) => {
            a.place.out.get_or_insert_with(|| repo_path("docs/results/envelope"));
            crate::common::place_defaults(&mut a.place);
            let command =
                std::iter::once("braille".to_string()).chain(std::env::args().skip(1)).collect::<Vec<_>>().join(" ");
            return crate::common::finish(experiments::reports::envelope::envelope(&a, &command, &Bar::default())?);
        }
        Some(Kind::Icub(a)) => return crate::icub_report::run(a),
        Some(Kind::Tactile(a)) => return crate::tactile_report::run(a),
        Some(Kind::Chip(a)) => return crate::chip_report::run(a),
        None => {}
    }
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
