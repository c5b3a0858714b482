//! `braille recordings`: a lab's own recorded scans, a folder of event files and a manifest
//! (docs/recordings.md).

use anyhow::Result;
use corpus::recordings::Recordings;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// Check a recordings folder (the manifest's every line and field, every event file read
    /// through) and summarise it per role and condition; nothing is written.
    Check {
        /// The folder holding manifest.csv.
        dir: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

pub fn run(args: Args) -> Result<()> {
    match args.command {
        Command::Check { dir, json } => crate::common::emit(&Recordings::open(&dir)?.check()?, json),
    }
}
