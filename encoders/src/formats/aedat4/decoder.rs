//! Streaming AEDAT 4.0 decoder: one packet in memory at a time, buffers reused.

use super::flatbuf::{Table, u32_at};
use super::{Compression, EVENT_BYTES, Framing, MAGIC, MAX_HEADER_BYTES, MAX_PACKET_BYTES};
use crate::error::{Error, Location, Result, io_at};
use crate::event::{Event, Polarity, Resolution};
use crate::formats::{Checker, EventSource, Format, OpenOptions, StreamInfo, io, read_up_to};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// One stream declared in a file's header.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct StreamDescription {
    pub id: u32,
    /// The FlatBuffer identifier of its packets: `EVTS`, `FRME`, `IMUS`, `TRIG`, ...
    pub type_identifier: String,
    pub resolution: Option<Resolution>,
    pub source: Option<String>,
}

/// Reads the events of one stream of an AEDAT4 file, packet by packet.
pub struct Decoder<R: Read = BufReader<File>> {
    path: PathBuf,
    reader: R,
    position: u64,
    compression: Compression,
    data_table_position: Option<u64>,
    streams: Vec<StreamDescription>,
    stream_id: u32,
    info: StreamInfo,
    checker: Checker,
    raw: Vec<u8>,
    decompressed: Vec<u8>,
    events: Vec<Event>,
    done: bool,
}

impl Decoder {
    /// Opens `path` and reads its header.
    pub fn open(path: &Path, options: &OpenOptions) -> Result<Self> {
        let file = File::open(path).map_err(|e| io(path, e))?;
        Self::from_reader(BufReader::with_capacity(1 << 20, file), path, options)
    }
}

impl<R: Read> Decoder<R> {
    /// Reads the header from `reader`; `path` names the input in errors.
    pub fn from_reader(reader: R, path: &Path, options: &OpenOptions) -> Result<Self> {
        Self::framed(reader, path, options, Framing::File)
    }

    /// Reads an AEDAT 4.0 network stream from `reader` (what DV and dv-processing's
    /// `NetworkWriter` send a client: the header without the magic, then packets, no table of
    /// packets); `name` names the stream in errors.
    pub fn from_network(reader: R, name: &Path, options: &OpenOptions) -> Result<Self> {
        Self::framed(reader, name, options, Framing::Network)
    }

    fn framed(mut reader: R, path: &Path, options: &OpenOptions, framing: Framing) -> Result<Self> {
        if framing == Framing::Network {
            let mut len = [0u8; 4];
            let n = read_up_to(&mut reader, &mut len).map_err(|e| io(path, e))?;
            if n == 0 {
                return Err(Error::Empty { path: path.into(), expected: "an AEDAT 4.0 network header".into() });
            }
            if n < 4 {
                return Err(Error::Truncated {
                    path: path.into(),
                    at: Location::Byte(n as u64),
                    expected: "the 4-byte header length".into(),
                });
            }
            return Self::after_magic(reader, path, options, 0, u32::from_le_bytes(len) as u64, framing);
        }
        let mut magic = [0u8; MAGIC.len()];
        let n = read_up_to(&mut reader, &mut magic).map_err(|e| io(path, e))?;
        if n == 0 {
            return Err(Error::Empty { path: path.into(), expected: "an AEDAT 4.0 header".into() });
        }
        if magic[..n] != MAGIC[..n] || n < MAGIC.len() {
            if magic[..n] == MAGIC[..n] {
                return Err(Error::Truncated {
                    path: path.into(),
                    at: Location::Byte(n as u64),
                    expected: "the rest of the 14-byte magic `#!AER-DAT4.0\\r\\n`".into(),
                });
            }
            return Err(Error::BadMagic {
                path: path.into(),
                at: Location::Byte(0),
                format: "AEDAT 4.0",
                expected: "`#!AER-DAT4.0\\r\\n`".into(),
                found: format!("{:?}", String::from_utf8_lossy(&magic[..n])),
            });
        }
        let position = MAGIC.len() as u64;
        let mut len = [0u8; 4];
        reader
            .read_exact(&mut len)
            .map_err(|e| io_at(path, Location::Byte(position), "the 4-byte header length", e))?;
        Self::after_magic(reader, path, options, position, u32::from_le_bytes(len) as u64, framing)
    }

    /// The rest of the header, from its length (read at byte `at`) on.
    fn after_magic(
        mut reader: R,
        path: &Path,
        options: &OpenOptions,
        at: u64,
        header_len: u64,
        framing: Framing,
    ) -> Result<Self> {
        let mut position = at + 4;
        if header_len > MAX_HEADER_BYTES {
            return Err(Error::TooLarge {
                path: path.into(),
                at: Location::Byte(position - 4),
                what: "the header",
                size: header_len,
                limit: MAX_HEADER_BYTES,
            });
        }
        let mut header = Vec::new();
        (&mut reader).take(header_len).read_to_end(&mut header).map_err(|e| io(path, e))?;
        if (header.len() as u64) < header_len {
            return Err(Error::Truncated {
                path: path.into(),
                at: Location::Byte(position + header.len() as u64),
                expected: format!("a {header_len}-byte header"),
            });
        }
        let corrupt = |what: String| Error::Corrupt { path: path.into(), at: Location::Byte(position), what };
        let table = Table::root(&header, b"IOHE").map_err(|e| corrupt(format!("header: {e}")))?;
        let code = table.i32_or(0, 0).map_err(|e| corrupt(format!("header: {e}")))?;
        let compression = Compression::from_code(code).ok_or(Error::UnknownCompression {
            path: path.into(),
            at: Location::Byte(position),
            value: code as i64,
        })?;
        let table_pos = table.i64_or(1, -1).map_err(|e| corrupt(format!("header: {e}")))?;
        let description = table
            .string(2)
            .map_err(|e| corrupt(format!("header: {e}")))?
            .ok_or_else(|| corrupt("header has no stream description".into()))?;
        let streams = parse_description(description).map_err(|e| corrupt(format!("stream description: {e}")))?;
        position += header_len;

        let chosen = match options.stream_id {
            Some(id) => streams.iter().find(|s| s.id == id && s.type_identifier == "EVTS").ok_or_else(|| {
                Error::Unsupported {
                    path: path.into(),
                    what: format!("no event (EVTS) stream with id {id}; {}", list(&streams)),
                }
            })?,
            None => streams.iter().find(|s| s.type_identifier == "EVTS").ok_or_else(|| Error::Unsupported {
                path: path.into(),
                what: format!("no event (EVTS) stream; {}", list(&streams)),
            })?,
        };
        let resolution = options.resolution.or(chosen.resolution);
        let info = StreamInfo { format: Format::Aedat4, resolution, source: chosen.source.clone() };
        Ok(Self {
            path: path.into(),
            reader,
            position,
            compression,
            // a network stream has no table of packets, whatever its header says
            data_table_position: if framing == Framing::File { u64::try_from(table_pos).ok() } else { None },
            stream_id: chosen.id,
            streams,
            info,
            checker: Checker::new(path, resolution),
            raw: Vec::new(),
            decompressed: Vec::new(),
            events: Vec::new(),
            done: false,
        })
    }

    /// Every stream the header declares.
    pub fn streams(&self) -> &[StreamDescription] {
        &self.streams
    }

    pub fn compression(&self) -> Compression {
        self.compression
    }

    /// Reads the next packet of the chosen stream into `self.events`; `false` at the end.
    fn next_packet(&mut self) -> Result<bool> {
        loop {
            if self.done || self.data_table_position.is_some_and(|p| self.position >= p) {
                self.done = true;
                return Ok(false);
            }
            let packet_offset = self.position;
            let mut head = [0u8; 8];
            let n = read_up_to(&mut self.reader, &mut head).map_err(|e| io(&self.path, e))?;
            if n == 0 {
                self.done = true;
                return Ok(false);
            }
            if n < 8 {
                return Err(Error::Truncated {
                    path: self.path.clone(),
                    at: Location::Byte(packet_offset + n as u64),
                    expected: "an 8-byte packet header (stream id, size)".into(),
                });
            }
            let stream_id = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
            let size = u32::from_le_bytes([head[4], head[5], head[6], head[7]]) as u64;
            if size > MAX_PACKET_BYTES {
                return Err(Error::TooLarge {
                    path: self.path.clone(),
                    at: Location::Byte(packet_offset),
                    what: "a packet",
                    size,
                    limit: MAX_PACKET_BYTES,
                });
            }
            self.position += 8 + size;
            self.raw.clear();
            // `take` grows the buffer as bytes arrive: a size claimed by a truncated file is
            // never allocated up front.
            (&mut self.reader).take(size).read_to_end(&mut self.raw).map_err(|e| io(&self.path, e))?;
            if (self.raw.len() as u64) < size {
                return Err(Error::Truncated {
                    path: self.path.clone(),
                    at: Location::Byte(packet_offset + 8 + self.raw.len() as u64),
                    expected: format!("a packet of {size} bytes starting at byte {packet_offset}"),
                });
            }
            if stream_id != self.stream_id {
                if !self.streams.iter().any(|s| s.id == stream_id) {
                    return Err(Error::Corrupt {
                        path: self.path.clone(),
                        at: Location::Byte(packet_offset),
                        what: format!("packet of stream {stream_id}, which the header does not declare"),
                    });
                }
                continue;
            }
            self.decode_packet(packet_offset)?;
            if !self.events.is_empty() {
                return Ok(true);
            }
        }
    }

    fn decode_packet(&mut self, packet_offset: u64) -> Result<()> {
        let corrupt =
            |what: String| Error::Corrupt { path: self.path.clone(), at: Location::Byte(packet_offset), what };
        let limit = MAX_PACKET_BYTES;
        let buf: &[u8] = match self.compression {
            Compression::None => &self.raw,
            Compression::Lz4 | Compression::Lz4High => {
                self.decompressed.clear();
                lz4_flex::frame::FrameDecoder::new(&self.raw[..])
                    .take(limit + 1)
                    .read_to_end(&mut self.decompressed)
                    .map_err(|e| corrupt(format!("LZ4 frame: {e}")))?;
                &self.decompressed
            }
            Compression::Zstd | Compression::ZstdHigh => {
                self.decompressed.clear();
                let decoder = zstd::stream::read::Decoder::with_buffer(&self.raw[..])
                    .map_err(|e| corrupt(format!("ZSTD frame: {e}")))?;
                decoder
                    .take(limit + 1)
                    .read_to_end(&mut self.decompressed)
                    .map_err(|e| corrupt(format!("ZSTD frame: {e}")))?;
                &self.decompressed
            }
        };
        if buf.len() as u64 > limit {
            return Err(Error::TooLarge {
                path: self.path.clone(),
                at: Location::Byte(packet_offset),
                what: "a decompressed packet",
                size: buf.len() as u64,
                limit,
            });
        }
        // DV writes packets size-prefixed; accept unprefixed ones too.
        let body = if buf.get(8..12) == Some(b"EVTS") {
            let prefix = u32_at(buf, 0).map_err(&corrupt)? as usize;
            if prefix + 4 > buf.len() {
                return Err(corrupt(format!("size prefix {prefix} exceeds the {}-byte packet", buf.len())));
            }
            &buf[4..4 + prefix]
        } else {
            buf
        };
        let table = Table::root(body, b"EVTS").map_err(|e| corrupt(format!("event packet: {e}")))?;
        let bytes = table.vector(0, EVENT_BYTES).map_err(|e| corrupt(format!("event packet: {e}")))?.unwrap_or(&[]);
        self.events.clear();
        self.events.reserve(bytes.len() / EVENT_BYTES);
        for (index, e) in bytes.chunks_exact(EVENT_BYTES).enumerate() {
            let t_us = i64::from_le_bytes([e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7]]);
            let x = i16::from_le_bytes([e[8], e[9]]);
            let y = i16::from_le_bytes([e[10], e[11]]);
            self.checker.check(t_us, x as i64, y as i64, || Location::PacketEvent { packet_offset, index })?;
            self.events.push(Event { t_us, x: x as u16, y: y as u16, polarity: Polarity::from_on(e[12] != 0) });
        }
        Ok(())
    }
}

impl<R: Read> EventSource for Decoder<R> {
    fn info(&self) -> &StreamInfo {
        &self.info
    }

    fn next_chunk(&mut self) -> Result<Option<&[Event]>> {
        Ok(if self.next_packet()? { Some(&self.events) } else { None })
    }

    fn path(&self) -> &Path {
        &self.path
    }
}

fn list(streams: &[StreamDescription]) -> String {
    let names: Vec<String> = streams.iter().map(|s| format!("{} ({})", s.id, s.type_identifier)).collect();
    format!("the file declares: {}", if names.is_empty() { "no streams".into() } else { names.join(", ") })
}

/// Reads the streams from DV's XML description:
/// `<dv><node name="outInfo"><node name="ID"><attr key="typeIdentifier">EVTS</attr>
/// <node name="info"><attr key="sizeX">640</attr>...`.
fn parse_description(xml: &str) -> Result<Vec<StreamDescription>, String> {
    let xml = xml.trim_end_matches('\0');
    let doc = roxmltree::Document::parse(xml).map_err(|e| e.to_string())?;
    let dv = doc.root_element();
    if !dv.has_tag_name("dv") {
        return Err(format!("root element is <{}>, expected <dv>", dv.tag_name().name()));
    }
    let out = dv
        .children()
        .find(|n| n.has_tag_name("node") && n.attribute("name") == Some("outInfo"))
        .ok_or("no <node name=\"outInfo\">")?;
    let attr = |node: roxmltree::Node, key: &str| {
        node.children()
            .find(|n| n.has_tag_name("attr") && n.attribute("key") == Some(key))
            .and_then(|n| n.text())
            .map(|t| t.trim().to_string())
    };
    let mut streams = Vec::new();
    for node in out.children().filter(|n| n.has_tag_name("node")) {
        let name = node.attribute("name").unwrap_or("");
        let id: u32 = name.parse().map_err(|_| format!("stream name {name:?} is not a number"))?;
        let type_identifier = attr(node, "typeIdentifier").ok_or(format!("stream {id} has no typeIdentifier"))?;
        let info = node.children().find(|n| n.has_tag_name("node") && n.attribute("name") == Some("info"));
        let size = |key| info.and_then(|i| attr(i, key)).map(|v| v.parse::<u16>());
        let resolution = match (size("sizeX"), size("sizeY")) {
            (Some(Ok(w)), Some(Ok(h))) => Some(Resolution::new(w, h)),
            (Some(Err(_)), _) | (_, Some(Err(_))) => {
                return Err(format!("stream {id} has a non-numeric sizeX or sizeY"));
            }
            _ => None,
        };
        let source = info.and_then(|i| attr(i, "source"));
        if streams.iter().any(|s: &StreamDescription| s.id == id) {
            return Err(format!("stream id {id} is declared twice"));
        }
        streams.push(StreamDescription { id, type_identifier, resolution, source });
    }
    Ok(streams)
}
