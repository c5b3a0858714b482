use anyhow::Result;
use encoders::formats::{self, OpenOptions};
use encoders::stats::StreamStats;
use encoders::{Format, Resolution};
use serde::Serialize;
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

#[derive(Serialize)]
struct Report {
    path: PathBuf,
    format: Format,
    resolution: Option<String>,
    source: Option<String>,
    events: u64,
    duration_s: f64,
    event_rate_hz: f64,
    on: u64,
    off: u64,
    on_off_ratio: Option<f64>,
    t_first_us: Option<i64>,
    t_last_us: Option<i64>,
    max_x: Option<u16>,
    max_y: Option<u16>,
}

pub fn run(args: Args) -> Result<()> {
    let options = OpenOptions { resolution: args.resolution, stream_id: args.stream };
    let mut source = formats::open(&args.file, &options)?;
    let mut stats = StreamStats::default();
    while let Some(chunk) = source.next_chunk()? {
        stats.add(chunk);
    }
    let info = source.info();
    let r = Report {
        path: args.file.clone(),
        format: info.format,
        resolution: info.resolution.map(|r| r.to_string()),
        source: info.source.clone(),
        events: stats.events,
        duration_s: stats.duration_s(),
        event_rate_hz: stats.rate_hz(),
        on: stats.on,
        off: stats.off,
        on_off_ratio: stats.on_off_ratio(),
        t_first_us: stats.t_first_us,
        t_last_us: stats.t_last_us,
        max_x: stats.max_x,
        max_y: stats.max_y,
    };
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
