//! Event files: one folder per format, each with a `decoder.rs` and an `encoder.rs`.
//!
//! Decoders stream: [`EventSource::next_chunk`] lends a slice of the next events from a buffer that
//! the decoder reuses, so memory stays bounded by the chunk (or packet) size, whatever the file's
//! length. Every decoder checks that timestamps never go backwards and that coordinates lie inside
//! the declared resolution, and names the file and the place when they do not.

pub mod aedat4;
mod atomic;
pub mod csv;
pub mod net;
pub mod npy;

pub use atomic::AtomicFile;

use crate::error::{Error, Location, Result};
use crate::event::{Event, Resolution};
use serde::Serialize;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Events handed out per chunk by the text and NumPy decoders.
pub const CHUNK_EVENTS: usize = 1 << 16;

/// The event file formats the project reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// AEDAT 4.0, the format of iniVation's DV software (DVXplorer, DAVIS).
    Aedat4,
    /// Text, one event per line: `t_us,x,y,p`.
    Csv,
    /// NumPy structured array with Tonic's fields `x, y, t, p`.
    Npy,
}

impl Format {
    pub const ALL: [Format; 3] = [Format::Aedat4, Format::Csv, Format::Npy];

    /// The format named by a file's extension (`.aedat4`, `.csv`, `.npy`).
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "aedat4" => Some(Format::Aedat4),
            "csv" | "txt" => Some(Format::Csv),
            "npy" => Some(Format::Npy),
            _ => None,
        }
    }

    /// The format announced by a file's first bytes, for the binary formats.
    pub fn sniff(head: &[u8]) -> Option<Format> {
        if head.starts_with(aedat4::MAGIC) {
            Some(Format::Aedat4)
        } else if head.starts_with(npy::MAGIC) {
            Some(Format::Npy)
        } else {
            None
        }
    }

    pub fn extension(self) -> &'static str {
        match self {
            Format::Aedat4 => "aedat4",
            Format::Csv => "csv",
            Format::Npy => "npy",
        }
    }

    /// The format to write `path` in, from its extension, or a clear error listing the choices.
    pub fn for_output(path: &Path) -> Result<Format> {
        Format::from_path(path).ok_or_else(|| Error::Unsupported {
            path: path.to_path_buf(),
            what: "cannot tell the output format from the extension; use .aedat4, .csv or .npy".into(),
        })
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Format::Aedat4 => "AEDAT4",
            Format::Csv => "CSV",
            Format::Npy => "NumPy",
        })
    }
}

/// What a stream says about itself before its events are read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StreamInfo {
    pub format: Format,
    /// The sensor size the file declares, if it declares one.
    pub resolution: Option<Resolution>,
    /// The recording device or program named in the file, if any.
    pub source: Option<String>,
}

/// A stream of events read in time order, chunk by chunk.
pub trait EventSource {
    fn info(&self) -> &StreamInfo;
    /// The next events, in time order, or `None` at the end of the stream. The slice is valid until
    /// the next call; it is never empty.
    fn next_chunk(&mut self) -> Result<Option<&[Event]>>;
    /// The file (or `-` for standard input) this source reads.
    fn path(&self) -> &Path;
}

/// A destination for events in time order.
pub trait EventSink {
    fn write(&mut self, events: &[Event]) -> Result<()>;
    /// Flushes everything and makes the output visible under its final name.
    fn finish(self: Box<Self>) -> Result<()>;
}

/// Options for opening an event file.
#[derive(Debug, Clone, Default)]
pub struct OpenOptions {
    /// The resolution to check coordinates against, overriding what the file declares.
    pub resolution: Option<Resolution>,
    /// AEDAT4 only: which stream to read; by default the first event (`EVTS`) stream.
    pub stream_id: Option<u32>,
}

/// Opens an event file for streaming, choosing the decoder from the file's magic bytes and then
/// its extension (anything else is read as CSV).
pub fn open(path: &Path, options: &OpenOptions) -> Result<Box<dyn EventSource>> {
    let mut head = [0u8; 16];
    let n = {
        let mut f = std::fs::File::open(path).map_err(|e| io(path, e))?;
        read_up_to(&mut f, &mut head).map_err(|e| io(path, e))?
    };
    let format = Format::sniff(&head[..n]).or_else(|| Format::from_path(path)).unwrap_or(Format::Csv);
    Ok(match format {
        Format::Aedat4 => Box::new(aedat4::Decoder::open(path, options)?),
        Format::Csv => Box::new(csv::Decoder::open(path, options)?),
        Format::Npy => Box::new(npy::Decoder::open(path, options)?),
    })
}

/// Opens standard input for streaming (named `-` in errors): AEDAT4 or NumPy by their magic
/// bytes, anything else read as CSV. Nothing is read ahead beyond the first 16 bytes, so a live
/// sensor piped in is read as it arrives.
pub fn open_stdin(options: &OpenOptions) -> Result<Box<dyn EventSource>> {
    let path = Path::new("-");
    let mut stdin = std::io::stdin();
    let mut head = [0u8; 16];
    let n = read_up_to(&mut stdin, &mut head).map_err(|e| io(path, e))?;
    let reader = std::io::Cursor::new(head[..n].to_vec()).chain(stdin);
    let reader = std::io::BufReader::with_capacity(1 << 16, reader);
    Ok(match Format::sniff(&head[..n]).unwrap_or(Format::Csv) {
        Format::Aedat4 => Box::new(aedat4::Decoder::from_reader(reader, path, options)?),
        Format::Csv => Box::new(csv::Decoder::from_reader(reader, path, options)?),
        Format::Npy => Box::new(npy::Decoder::from_reader(reader, path, options)?),
    })
}

/// Opens an event source by the name a user gives it: `-` for standard input ([`open_stdin`]),
/// `tcp://HOST:PORT` for a live AEDAT 4.0 network stream ([`net::connect`], with `net`'s
/// timeouts), anything else a file ([`open`]).
pub fn open_named(name: &Path, options: &OpenOptions, net: &net::ConnectOptions) -> Result<Box<dyn EventSource>> {
    if name.as_os_str() == "-" {
        return open_stdin(options);
    }
    if let Some(address) = name.to_str().and_then(net::tcp_address) {
        return Ok(Box::new(net::connect(address, options, net)?));
    }
    open(name, options)
}

/// Creates an event file in the format its extension names. The file appears under its name only
/// when [`EventSink::finish`] succeeds; an existing file is replaced only with `force`.
pub fn create(path: &Path, resolution: Option<Resolution>, force: bool) -> Result<Box<dyn EventSink>> {
    let format = Format::for_output(path)?;
    let file = AtomicFile::create(path, force)?;
    Ok(match format {
        Format::Aedat4 => Box::new(aedat4::Encoder::new(file, resolution, aedat4::EncoderOptions::default())?),
        Format::Csv => Box::new(csv::Encoder::new(file, resolution)?),
        Format::Npy => Box::new(npy::Encoder::new(file)?),
    })
}

/// Reads a whole file into memory. Use [`open`] to stream instead.
pub fn read_all(path: &Path, options: &OpenOptions) -> Result<(StreamInfo, Vec<Event>)> {
    let mut source = open(path, options)?;
    let mut events = Vec::new();
    while let Some(chunk) = source.next_chunk()? {
        events.extend_from_slice(chunk);
    }
    Ok((source.info().clone(), events))
}

/// Copies every event of `source` into `sink`, chunk by chunk, and returns how many were copied.
pub fn copy(source: &mut dyn EventSource, sink: &mut dyn EventSink) -> Result<u64> {
    let mut n = 0u64;
    while let Some(chunk) = source.next_chunk()? {
        sink.write(chunk)?;
        n += chunk.len() as u64;
    }
    Ok(n)
}

pub(crate) fn io(path: &Path, e: std::io::Error) -> Error {
    Error::Io { path: path.to_path_buf(), source: e }
}

/// Reads until `buf` is full or the input ends; returns the number of bytes read.
pub(crate) fn read_up_to(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// The order and range checks every decoder applies to what it hands out.
#[derive(Debug, Clone)]
pub(crate) struct Checker {
    pub path: PathBuf,
    pub resolution: Option<Resolution>,
    pub last_t_us: i64,
}

impl Checker {
    pub fn new(path: &Path, resolution: Option<Resolution>) -> Self {
        Self { path: path.to_path_buf(), resolution, last_t_us: i64::MIN }
    }

    /// Checks one event given as wide integers; `at` names its place for the error.
    #[inline]
    pub fn check(&mut self, t_us: i64, x: i64, y: i64, at: impl FnOnce() -> Location) -> Result<()> {
        if t_us < self.last_t_us {
            return Err(Error::TimestampBackwards {
                path: self.path.clone(),
                at: at(),
                t_us,
                previous_us: self.last_t_us,
            });
        }
        self.last_t_us = t_us;
        let (w, h) = match self.resolution {
            Some(r) => (r.width as i64, r.height as i64),
            None => (u16::MAX as i64 + 1, u16::MAX as i64 + 1),
        };
        if x < 0 || y < 0 || x >= w || y >= h {
            let r = self.resolution.unwrap_or(Resolution::new(u16::MAX, u16::MAX));
            return Err(Error::OutOfRange {
                path: self.path.clone(),
                at: at(),
                x,
                y,
                width: r.width,
                height: r.height,
            });
        }
        Ok(())
    }
}
