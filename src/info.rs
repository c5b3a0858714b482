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
    crate::common::emit(&FileSummary::of(&args.file, &options)?, args.json)
}
