//! `braille replay`: serve an event file as a live sensor would, in DV's AEDAT 4.0 network
//! framing at the recorded pace, to `braille read tcp://HOST:PORT`, dv-processing's
//! `NetworkReader` or DV itself.

use anyhow::{Context, Result};
use corpus::scans::RowStream;
use encoders::Resolution;
use encoders::formats::net::{ReplayOptions, serve};
use encoders::formats::{self, OpenOptions};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Event file (.aedat4, .csv, .npy) [or, with --board, SIMULATED rows].
    #[arg(required_unless_present = "board")]
    file: Option<PathBuf>,
    /// Serve SIMULATED rows of this board instead of a file, one after another (row after row,
    /// then the rows again with new trials), each simulated when the stream reaches it: a long
    /// session with bounded memory. `nominal` and its first test sensor build, the test seed.
    #[arg(long, conflicts_with = "file")]
    board: Option<sim::BoardKind>,
    /// --board: minutes of stream to serve.
    #[arg(long, default_value_t = 1.0, requires = "board")]
    stream_min: f64,
    /// --board: the sliding speed, mm/s.
    #[arg(long, default_value_t = 16.0, requires = "board")]
    speed: f64,
    /// --board: the indentation depth, mm.
    #[arg(long, default_value_t = 1.0, requires = "board")]
    depth: f64,
    /// Address to listen on, HOST:PORT (port 0 picks a free one; the address is printed).
    #[arg(long)]
    listen: String,
    /// Stream time per wall time: 1 is the recorded pace, 0 as fast as the client reads.
    #[arg(long, default_value_t = 1.0)]
    pace: f64,
    /// The longest stretch of stream time in one packet, in ms (DV sends about one per ms).
    #[arg(long, default_value_t = 1.0)]
    packet_ms: f64,
    /// Packet compression.
    #[arg(long, value_enum, default_value = "none")]
    compression: crate::common::CompressionArg,
    /// Seconds to keep the connection open after the last packet, until the client closes it:
    /// dv-processing's NetworkReader drops the packets it has not handed out when the sender
    /// closes first. 0 closes at once (what `braille read` takes as the end of the stream).
    #[arg(long, default_value_t = 0.0)]
    linger_s: f64,
    /// Clients to serve, one after another, each the whole file from its start.
    #[arg(long, default_value_t = 1)]
    clients: u32,
    /// The sensor's resolution, WIDTHxHEIGHT [default: what the file declares, else 640x480].
    #[arg(long)]
    resolution: Option<Resolution>,
    /// One JSON object per client served.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let listener =
        std::net::TcpListener::bind(&args.listen).with_context(|| format!("listening on {}", args.listen))?;
    let address = listener.local_addr()?;
    let options = ReplayOptions {
        pace: args.pace,
        packet_us: (args.packet_ms * 1e3).round() as i64,
        compression: args.compression.compression(),
        linger: std::time::Duration::from_secs_f64(args.linger_s.max(0.0)),
    };
    let what = match (&args.file, &args.board) {
        (Some(f), _) => f.display().to_string(),
        (None, Some(b)) => format!("SIMULATED rows of {} for {} min", b.name(), args.stream_min),
        (None, None) => unreachable!("clap requires a file or a board"),
    };
    // the address first, so that a script can start its client
    eprintln!("serving {what} on tcp://{address}");
    for _ in 0..args.clients {
        let mut source: Box<dyn encoders::EventSource> = match (&args.file, &args.board) {
            (Some(file), _) => formats::open(file, &OpenOptions { resolution: args.resolution, stream_id: None })?,
            (None, Some(board)) => {
                let resolution = args.resolution.unwrap_or(Resolution::DVXPLORER);
                let stream_s = args.stream_min * 60.0;
                Box::new(RowStream::nominal_test(board.clone(), resolution, args.speed, args.depth, stream_s)?)
            }
            (None, None) => unreachable!("clap requires a file or a board"),
        };
        let resolution = args.resolution.or(source.info().resolution).unwrap_or(Resolution::DVXPLORER);
        let s = serve(&listener, source.as_mut(), resolution, &options)?;
        if args.json {
            println!("{}", serde_json::to_string(&s)?);
        } else {
            print!("{s}");
        }
    }
    Ok(())
}
