//! `braille simulate`: scans of Braille boards by the virtual Evetac, written as event files with
//! their ground truth.

use anyhow::Result;
use corpus::scans::ScanSpec;
use encoders::Resolution;
use pipeline::code::BrailleCode;
use sim::{Direction, Realism};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Board: SAB, UN, RAB, VAL (validation), EV, VAL-WORDS, VAL-LETTERS (validation words and
    /// letters), ALL-LETTERS, or text:"ANY WORDS" (`/` starts a new row; long rows wrap), its
    /// print written in `--braille`'s code (Unicode Braille cells are printed as they are).
    #[arg(long, default_value = "EV")]
    pub board: String,
    /// The Braille code a `text:` board's print is written in: the paper's letters, or Unified
    /// English Braille uncontracted or contracted (liblouis's tables; `braille translate`).
    #[arg(long, value_enum, default_value_t = BrailleCode::Grade1Letters)]
    pub braille: BrailleCode,
    /// Sliding speed (the paper: 8-32 mm/s).
    #[arg(long, default_value_t = 8.0)]
    pub speed: f64,
    /// Indentation depth from first contact (the paper: 0.2-1.5 mm).
    #[arg(long, default_value_t = 1.5)]
    pub depth: f64,
    /// Row to scan [default: every row].
    #[arg(long)]
    pub row: Option<usize>,
    /// Scans per row.
    #[arg(long, default_value_t = 1)]
    pub trials: u64,
    /// Seed of the trials (misalignment, speed ripple, noise).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seed of the printed board's tolerances [default: derived from the board's name].
    #[arg(long)]
    pub board_seed: Option<u64>,
    /// Seed of the sensor build: its pixels (thresholds, hot pixels) and, beyond `clean`, its gel,
    /// LED and noise rates.
    #[arg(long, default_value_t = 1)]
    pub sensor_seed: u64,
    /// The simulator's nuisances (docs/simulator.md); `clean` is the simulator before them, kept
    /// for regression.
    #[arg(long, value_enum, default_value_t = Realism::Nominal)]
    pub realism: Realism,
    #[arg(long, value_enum, default_value_t = Direction::Forward)]
    pub direction: Direction,
    /// Stick-slip of the gel on the board's face, seen through a mount of this compliance (um per
    /// N; 33 is `harsh`'s mount, 10 `nominal`'s, 0 a rigid one), the rest of the mount as
    /// `sim::StickSlip::LIGHT_MOUNT` [default: the preset's: none at `clean`].
    #[arg(long)]
    pub mount_compliance_um_per_n: Option<f64>,
    /// Sensor resolution; the field of view stays the build's width (18.6 mm by design, drawn
    /// per build beyond `clean`).
    #[arg(long, default_value = "640x480")]
    pub resolution: Resolution,
    /// An event file (.aedat4, .csv, .npy) for one scan, or a folder for several.
    #[arg(long)]
    pub out: PathBuf,
    /// Write the scans as a lab's recordings folder instead (`--out` is the folder): numbered
    /// AEDAT4 files with no ground truth, their lines appended to its manifest.csv with this role,
    /// the row's text and the commanded speed and depth (docs/recordings.md).
    #[arg(long, value_enum)]
    pub recordings: Option<corpus::recordings::Role>,
    /// --recordings: write the scans `eval words` reads at these sensor builds (the same board,
    /// speed, depth, trials, seed and preset: the world's scan seeds, trial k on its build k mod
    /// builds), instead of `simulate`'s own seeds and `--sensor-seed`.
    #[arg(long, value_enum, requires = "recordings")]
    pub sensor_builds: Option<corpus::world::SensorBuilds>,
    /// Replace existing outputs.
    #[arg(long)]
    pub force: bool,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let spec = ScanSpec {
        board: corpus::boards::parse_board_in(&args.board, args.braille)?,
        speed: args.speed,
        depth: args.depth,
        row: args.row,
        trials: args.trials,
        seed: args.seed,
        board_seed: args.board_seed,
        sensor_seed: args.sensor_seed,
        realism: args.realism,
        direction: args.direction,
        stick_slip: args.mount_compliance_um_per_n.map(|c| sim::StickSlip::light_mount_with_compliance(c.max(1e-3))),
        resolution: args.resolution,
        out: args.out,
        force: args.force,
    };
    let quiet = crate::common::Bar::default();
    if let Some(role) = args.recordings {
        let world = args.sensor_builds.map(|b| corpus::World::of(args.realism, b));
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
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        for f in &summary.files {
            println!(
                "{} ({} events, {:.1} s; truth {})",
                f.events.display(),
                f.events_count,
                f.duration_s,
                f.truth.display()
            );
        }
        println!(
            "simulated {} scans of {}: {} events, ON/OFF {:.2}",
            summary.scans,
            summary.board,
            summary.events,
            summary.on_off_ratio.unwrap_or(f64::NAN)
        );
    }
    Ok(())
}
