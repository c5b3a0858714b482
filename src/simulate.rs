//! `braille simulate`: scans of Braille boards by the virtual Evetac, written as event files with
//! their ground truth.

use anyhow::Result;
use corpus::scans::ScanSpec;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    spec: ScanSpec,
    /// Write the scans as a lab's recordings folder instead (`--out` is the folder): numbered
    /// AEDAT4 files with no ground truth, their lines appended to its manifest.csv with this role,
    /// the row's text and the commanded speed and depth (docs/recordings.md).
    #[arg(long, value_enum)]
    recordings: Option<corpus::recordings::Role>,
    /// --recordings: write the scans `eval words` reads at these sensor builds (the same board,
    /// speed, depth, trials, seed and preset: the world's scan seeds, trial k on its build k mod
    /// builds), instead of `simulate`'s own seeds and `--sensor-seed`.
    #[arg(long, value_enum, requires = "recordings")]
    sensor_builds: Option<corpus::world::SensorBuilds>,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let spec = args.spec;
    let quiet = crate::common::Bar::default();
    if let Some(role) = args.recordings {
        let world = args.sensor_builds.map(|b| corpus::World::of(spec.realism, b));
        let written = corpus::recordings::export(&spec, world.as_ref(), role, if args.json { &() } else { &quiet })?;
        if args.json {
            println!("{}", serde_json::to_string_pretty(&written)?);
        } else {
            for r in &written {
                println!(
                    "{}: {} {:?} at {} mm/s, {} mm",
                    spec.out.join(&r.file).display(),
                    r.role.name(),
                    r.text,
                    r.speed_mm_s,
                    r.depth_mm
                );
            }
            println!("{} scans added to {}", written.len(), spec.out.join(corpus::recordings::MANIFEST).display());
        }
        return Ok(());
    }
    let summary = corpus::scans::simulate_files(&spec, if args.json { &() } else { &quiet })?;
    crate::common::emit(&summary, args.json)
}
