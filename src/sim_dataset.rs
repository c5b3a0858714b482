//! `braille sim dataset`: a SIMULATED tactile dataset of another layout than the iCub sets (a
//! grid of event taxels under each Braille character), written as a dataset folder.

use anyhow::Result;
use corpus::taxels::{TaxelSetSpec, make_taxel_dataset};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The dataset folder to write (`samples.csv`, `events.csv`, `split.csv`, `dataset.json`).
    #[arg(long)]
    out: PathBuf,
    /// Taxels across (along the slide) and down, as COLSxROWS.
    #[arg(long, default_value = "5x4")]
    taxels: String,
    /// The patch the taxels tile, centred on the sensor, in mm, as WIDTHxHEIGHT.
    #[arg(long, default_value = "6x8")]
    patch_mm: String,
    /// A taxel's event threshold: pixel events of one polarity per taxel event.
    #[arg(long, default_value_t = 256)]
    pixel_events_per_event: u32,
    /// Scans of every training board row (SAB).
    #[arg(long, default_value_t = 40)]
    train_trials: u64,
    /// Scans of every test board row (RAB).
    #[arg(long, default_value_t = 10)]
    test_trials: u64,
    /// Each scan's speed is drawn from this range, mm/s, as LOW-HIGH.
    #[arg(long, default_value = "10-30")]
    speeds: String,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    #[arg(long, value_enum, default_value_t = sim::Realism::Nominal)]
    realism: sim::Realism,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Replace existing files.
    #[arg(long)]
    force: bool,
}

fn pair<T: std::str::FromStr>(s: &str, sep: char, what: &str) -> Result<(T, T)> {
    let bad = || anyhow::anyhow!("{what}: expected two numbers as A{sep}B, got {s:?}");
    let (a, b) = s.split_once(sep).ok_or_else(bad)?;
    Ok((a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?))
}

pub fn run(args: Args) -> Result<()> {
    let (taxels_x, taxels_y) = pair(&args.taxels, 'x', "--taxels")?;
    let spec = TaxelSetSpec {
        train_trials: args.train_trials,
        test_trials: args.test_trials,
        speed_range_mm_s: pair(&args.speeds, '-', "--speeds")?,
        depth_mm: args.depth,
        taxels_x,
        taxels_y,
        patch_mm: pair(&args.patch_mm, 'x', "--patch-mm")?,
        pixel_events_per_event: args.pixel_events_per_event,
        realism: args.realism,
        seed: args.seed,
        ..TaxelSetSpec::default()
    };
    let s = make_taxel_dataset(&spec, &args.out, args.force, &crate::common::Bar::default())?;
    println!("{}: {s}", args.out.display());
    Ok(())
}
