//! `braille report chip`: what exporting the shipped SNNs faithfully costs, and the chip table
//! (each exportable model against each chip's rules, with accuracy, work and energy estimates).

use crate::common::Bar;
use anyhow::Result;
use experiments::reports::chips::{self, ChipSpec};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The shipped models' folder: the simulated ones in `REALISM/`, the iCub ones in `icub/`,
    /// each with its reset-to-zero twins in `nir/` (`bash scripts/train_nir.sh`) and its chip
    /// models in `chip/` (`bash scripts/train_chips.sh`) [default: the repository's `models/`].
    #[arg(long)]
    models: Option<PathBuf>,
    /// Folder holding the iCub dataset folders `raw1350` and `th10`.
    #[arg(long, default_value = "data/icub_braille")]
    data: PathBuf,
    /// Simulated scans per board row.
    #[arg(long, default_value_t = 30)]
    trials: u64,
    #[command(flatten)]
    realism: crate::common::RealismArg,
    /// Where to write `chips.md` and `chips.json`.
    #[arg(long, default_value = "docs/results")]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let spec = ChipSpec {
        models: args.models.map_or_else(crate::common::shipped, pipeline::shipped::Shipped::at),
        icub: args.data,
        trials: args.trials,
        realism: args.realism.realism,
    };
    let r = chips::run(&spec, &Bar::default())?;
    let md = chips::markdown(&r);
    std::fs::create_dir_all(&args.out)?;
    experiments::write_json(&args.out.join("chips.json"), &r, true)?;
    std::fs::write(args.out.join("chips.md"), &md)?;
    print!("{md}");
    Ok(())
}
