//! `braille plot`: a scan as a heat map (events per pooled pixel, ON and OFF) and as an event
//! raster (pooled column against time), as a PNG.

use anyhow::{Result, bail};
use encoders::formats::{self, OpenOptions};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Event file (.aedat4, .csv, .npy).
    file: PathBuf,
    /// PNG to write.
    #[arg(long)]
    out: PathBuf,
    /// Spatial pooling of the pictures (the paper: 4).
    #[arg(long, default_value_t = 4)]
    pool: u16,
    /// Heat-map window: start and length in seconds from the first event [default: the busiest
    /// 0.35 s, one character at 8 mm/s].
    #[arg(long)]
    window_start_s: Option<f64>,
    #[arg(long, default_value_t = 0.35)]
    window_s: f64,
    /// Title; "simulated" belongs in it for simulated data.
    #[arg(long, default_value = "")]
    title: String,
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> Result<()> {
    if args.out.exists() && !args.force {
        bail!("{}: exists; pass --force to overwrite it", args.out.display());
    }
    let (info, events) = formats::read_all(&args.file, &OpenOptions::default())?;
    if events.is_empty() {
        bail!("{}: no events to plot", args.file.display());
    }
    let title = if args.title.is_empty() { args.file.display().to_string() } else { args.title.clone() };
    let window = experiments::reports::figures::ScanWindow {
        pool: args.pool,
        start_s: args.window_start_s,
        length_s: args.window_s,
    };
    experiments::reports::figures::scan_figure(&events, info.resolution, &window, &title, &args.out)?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
