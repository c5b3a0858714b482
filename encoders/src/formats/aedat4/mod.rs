//! AEDAT 4.0, the file format of iniVation's DV software, which records the DVXplorer that Evetac
//! uses.
//!
//! Layout: the magic `#!AER-DAT4.0\r\n`; a little-endian `u32` length and an `IOHeader`
//! FlatBuffer (compression, file data table position, an XML description of the streams); then
//! packets, each a `u32` stream id, a `u32` byte size and a FlatBuffer (size-prefixed, identifier
//! `EVTS` for events) compressed as the header says (LZ4 frame or ZSTD frame, or none). Files may
//! hold several streams (events, frames, IMU, triggers); the decoder reads one event stream. DV's
//! network stream is the same without the magic ([`Framing::Network`]).

mod decoder;
mod encoder;
mod flatbuf;

pub use decoder::{Decoder, StreamDescription};
pub use encoder::{Encoder, EncoderOptions};

/// How the header and packets are framed: a file (the magic first, and maybe a table of packets
/// at the end), or DV's network stream (the same header and packets without the magic: what
/// DV's TCP outputs and dv-processing's `NetworkWriter` send each client).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Framing {
    File,
    Network,
}

/// The 14 bytes every AEDAT 4.0 file starts with.
pub const MAGIC: &[u8] = b"#!AER-DAT4.0\r\n";

/// The largest packet the decoder accepts, compressed or not: DV writes packets of kilobytes to
/// a few megabytes, so a larger size means a corrupt file, not a reason to allocate.
pub const MAX_PACKET_BYTES: u64 = 256 << 20;

/// The largest header the decoder accepts.
pub const MAX_HEADER_BYTES: u64 = 16 << 20;

/// Bytes of one event in an `EVTS` packet: `t: i64, x: i16, y: i16, on: bool`, padded to 16.
pub(crate) const EVENT_BYTES: usize = 16;

/// How packets are compressed; one setting for the whole file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Compression {
    None,
    #[default]
    Lz4,
    Lz4High,
    Zstd,
    ZstdHigh,
}

impl Compression {
    pub fn from_code(code: i32) -> Option<Self> {
        Some(match code {
            0 => Compression::None,
            1 => Compression::Lz4,
            2 => Compression::Lz4High,
            3 => Compression::Zstd,
            4 => Compression::ZstdHigh,
            _ => return None,
        })
    }

    pub fn code(self) -> i32 {
        match self {
            Compression::None => 0,
            Compression::Lz4 => 1,
            Compression::Lz4High => 2,
            Compression::Zstd => 3,
            Compression::ZstdHigh => 4,
        }
    }

    /// The name DV writes in a stream's `compression` attribute.
    pub fn dv_name(self) -> &'static str {
        match self {
            Compression::None => "NONE",
            Compression::Lz4 => "LZ4",
            Compression::Lz4High => "LZ4_HIGH",
            Compression::Zstd => "ZSTD",
            Compression::ZstdHigh => "ZSTD_HIGH",
        }
    }
}
