use anyhow::Result;
use encoders::Resolution;
use encoders::formats::OpenOptions;
use encoders::stats::FileSummary;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Event file (.aedat4, .csv, .npy).
    file: PathBuf,
    /// Check coordinates against this resolution (WIDTHxHEIGHT) instead of the declared one.
    #[arg(long)]
    resolution: Option<Resolution>,
    /// AEDAT4: read this stream id instead of the first event stream.
    #[arg(long)]
    stream: Option<u32>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let options = OpenOptions { resolution: args.resolution, stream_id: args.stream };
    let r = FileSummary::of(&args.file, &options)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    let opt = |v: Option<String>| v.unwrap_or_else(|| "-".into());
    println!("file         {}", r.path.display());
    println!("format       {}", r.format);
    println!("resolution   {}", opt(r.resolution.clone()).replace('-', "not declared"));
    if let Some(s) = &r.source {
        println!("source       {s}");
    }
    println!("events       {} ({} ON, {} OFF)", r.events, r.on, r.off);
    println!("ON/OFF ratio {}", opt(r.on_off_ratio.map(|v| format!("{v:.3}"))));
    println!("duration     {:.6} s", r.duration_s);
    println!("event rate   {:.1} events/s", r.event_rate_hz);
    println!(
        "time range   {} .. {} us",
        opt(r.t_first_us.map(|v| v.to_string())),
        opt(r.t_last_us.map(|v| v.to_string()))
    );
    println!("max x, y     {}, {}", opt(r.max_x.map(|v| v.to_string())), opt(r.max_y.map(|v| v.to_string())));
    Ok(())
}
