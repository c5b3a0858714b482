//! `braille ensemble`: trained SNNs of one architecture merged into one network
//! ([`experiments::train::fit::ensemble`]), which the engine runs and NIR exports like any other.

use anyhow::{Result, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A member's model file; give two or more. All must share the architecture, step, readout,
    /// input encoding and classes.
    #[arg(long = "model", required = true)]
    models: Vec<PathBuf>,
    /// Model file to write.
    #[arg(long)]
    out: PathBuf,
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> Result<()> {
    if args.out.exists() && !args.force {
        bail!("{}: exists; pass --force to replace it", args.out.display());
    }
    let model = experiments::train::fit::ensemble(&args.models)?;
    experiments::train::fit::save_model(&model, &args.out, args.force)?;
    eprintln!("wrote {} ({} members)", args.out.display(), args.models.len());
    Ok(())
}
