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
        Command::Check { dir, json } => {
            let r = Recordings::open(&dir)?;
            let s = r.check()?;
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
                return Ok(());
            }
            println!("{}: {} scans", s.dir.display(), s.scans);
            println!("| role | speed (mm/s) | depth (mm) | scans | characters | events | duration (s) | events/s |");
            println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
            for g in &s.groups {
                println!(
                    "| {} | {} | {} | {} | {} | {} | {:.1} | {:.0} |",
                    g.role.name(),
                    g.speed_mm_s,
                    g.depth_mm,
                    g.scans,
                    g.characters,
                    g.events,
                    g.duration_s,
                    g.event_rate_hz
                );
            }
            for role in &s.roles {
                println!(
                    "{}: {} scans, {} characters, {} events, {:.1} s",
                    role.role.name(),
                    role.scans,
                    role.characters,
                    role.events,
                    role.duration_s
                );
            }
            for g in &s.groups {
                for f in &g.empty_files {
                    println!("note: {} holds no events", f.display());
                }
            }
            Ok(())
        }
    }
}
