use anyhow::{Context, Result};
use encoders::formats::aedat4::{self, EncoderOptions};
use encoders::formats::{self, AtomicFile, EventSink, OpenOptions};
use encoders::{Format, Resolution};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Input event file (.aedat4, .csv, .npy), `-` for standard input, or `tcp://HOST:PORT` to
    /// record a live AEDAT 4.0 network stream until the sender closes it.
    input: PathBuf,
    #[command(flatten)]
    live: crate::common::LiveArgs,
    /// Output event file; its extension (.aedat4, .csv, .npy) chooses the format.
    output: PathBuf,
    /// Replace the output if it exists.
    #[arg(long)]
    force: bool,
    /// Resolution (WIDTHxHEIGHT) for inputs that declare none; AEDAT4 output needs one
    /// [default: the input's, else 640x480].
    #[arg(long)]
    resolution: Option<Resolution>,
    /// AEDAT4 input: read this stream id instead of the first event stream.
    #[arg(long)]
    stream: Option<u32>,
    /// AEDAT4 output: packet compression.
    #[arg(long, value_enum, default_value = "lz4")]
    compression: crate::common::CompressionArg,
    /// AEDAT4 output: events per packet.
    #[arg(long, default_value_t = 8192)]
    packet_events: usize,
    /// Pass the events through a background-activity filter first (`encoders::denoise`):
    /// `dv-lab` (DV's noise filter as the seed's lab records through it) or `dv-processing` (its
    /// BackgroundActivityNoiseFilter), `:WINDOW_US` for another window.
    #[arg(long)]
    denoise: Option<encoders::denoise::NoiseFilterSettings>,
}

pub fn run(args: Args) -> Result<()> {
    let options = OpenOptions { resolution: args.resolution, stream_id: args.stream };
    let source = formats::open_named(&args.input, &options, &args.live.options())?;
    let resolution = source.info().resolution;
    let format = Format::for_output(&args.output)?;
    let mut sink: Box<dyn EventSink> = match format {
        Format::Aedat4 => {
            let compression = args.compression.compression();
            let file = AtomicFile::create(&args.output, args.force)?;
            let opts =
                EncoderOptions { compression, packet_events: args.packet_events, source: "braille convert".into() };
            Box::new(aedat4::Encoder::new(file, resolution, opts)?)
        }
        _ => formats::create(&args.output, resolution, args.force)?,
    };
    let mut source =
        encoders::denoise::Denoised::new(source, Resolution::DVXPLORER, args.denoise).map_err(anyhow::Error::msg)?;
    let n = formats::copy(&mut source, sink.as_mut()).with_context(|| {
        if format == Format::Aedat4 && resolution.is_none() {
            format!("{} declares no resolution; pass --resolution WIDTHxHEIGHT", args.input.display())
        } else {
            format!("converting {} to {}", args.input.display(), args.output.display())
        }
    })?;
    sink.finish()?;
    if let Some((settings, stats)) = source.stats() {
        eprintln!("denoised ({settings}): {stats}");
    }
    eprintln!("wrote {n} events to {} ({format})", args.output.display());
    Ok(())
}
