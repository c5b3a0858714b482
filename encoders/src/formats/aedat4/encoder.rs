//! AEDAT 4.0 encoder: one event stream, packets of a fixed number of events.

use super::flatbuf::PutLe;
use super::{Compression, EVENT_BYTES, Framing, MAGIC};
use crate::error::{Error, Location, Result};
use crate::event::{Event, Resolution};
use crate::formats::{AtomicFile, EventSink};
use std::io::Write;

/// How an AEDAT4 file is written.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EncoderOptions {
    pub compression: Compression,
    /// Events per packet. DV's own packets hold one readout each; larger packets compress and
    /// decode faster.
    pub packet_events: usize,
    /// The `source` attribute of the stream (DV puts the camera's name there).
    pub source: String,
}

impl Default for EncoderOptions {
    fn default() -> Self {
        Self { compression: Compression::Lz4, packet_events: 8192, source: "braille".into() }
    }
}

/// Writes one event stream (id 0) as AEDAT 4.0.
pub struct Encoder<W: Write = AtomicFile> {
    writer: W,
    name: std::path::PathBuf,
    options: EncoderOptions,
    resolution: Resolution,
    pending: Vec<Event>,
    flat: Vec<u8>,
    packed: Vec<u8>,
    position: u64,
    last_t_us: i64,
}

impl Encoder<AtomicFile> {
    /// Starts an AEDAT4 file. Coordinates must lie inside `resolution` (by default the
    /// DVXplorer's 640x480).
    pub fn new(file: AtomicFile, resolution: Option<Resolution>, options: EncoderOptions) -> Result<Self> {
        let name = file.path().to_path_buf();
        Encoder::to_writer(file, &name, resolution, options)
    }
}

impl<W: Write> Encoder<W> {
    /// Starts an AEDAT4 file on any writer; `name` names it in errors.
    pub fn to_writer(
        writer: W,
        name: &std::path::Path,
        resolution: Option<Resolution>,
        options: EncoderOptions,
    ) -> Result<Self> {
        Self::framed(writer, name, resolution, options, Framing::File)
    }

    /// Starts an AEDAT 4.0 network stream on `writer` (a client's socket: the header without the
    /// magic, then packets, as DV's TCP outputs send them); `name` names it in errors.
    pub fn to_network(
        writer: W,
        name: &std::path::Path,
        resolution: Option<Resolution>,
        options: EncoderOptions,
    ) -> Result<Self> {
        Self::framed(writer, name, resolution, options, Framing::Network)
    }

    fn framed(
        writer: W,
        name: &std::path::Path,
        resolution: Option<Resolution>,
        options: EncoderOptions,
        framing: Framing,
    ) -> Result<Self> {
        if options.packet_events == 0 {
            return Err(Error::config("packet_events", "must be at least 1"));
        }
        let resolution = resolution.unwrap_or(Resolution::DVXPLORER);
        if resolution.width > i16::MAX as u16 || resolution.height > i16::MAX as u16 {
            return Err(Error::config(
                "resolution",
                format!("AEDAT4 stores coordinates as i16; {resolution} is too large"),
            ));
        }
        let mut encoder = Self {
            writer,
            name: name.to_path_buf(),
            pending: Vec::with_capacity(options.packet_events),
            options,
            resolution,
            flat: Vec::new(),
            packed: Vec::new(),
            position: 0,
            last_t_us: i64::MIN,
        };
        let header = io_header(encoder.options.compression, &description(resolution, &encoder.options));
        let mut head = if framing == Framing::File { MAGIC.to_vec() } else { Vec::new() };
        head.put_u32(header.len() as u32);
        head.extend_from_slice(&header);
        encoder.put(&head)?;
        Ok(encoder)
    }

    fn put(&mut self, bytes: &[u8]) -> Result<()> {
        put(&mut self.writer, &mut self.position, &self.name, bytes)
    }

    fn flush_packet(&mut self) -> Result<()> {
        if self.pending.is_empty() {
            return Ok(());
        }
        event_packet(&self.pending, &mut self.flat);
        let body: &[u8] = match self.options.compression {
            Compression::None => &self.flat,
            Compression::Lz4 | Compression::Lz4High => {
                self.packed.clear();
                let mut enc = lz4_flex::frame::FrameEncoder::new(&mut self.packed);
                enc.write_all(&self.flat)
                    .and_then(|_| enc.finish().map(|_| ()).map_err(std::io::Error::other))
                    .map_err(|e| Error::Io { path: self.name.clone(), source: e })?;
                &self.packed
            }
            Compression::Zstd | Compression::ZstdHigh => {
                let level = if self.options.compression == Compression::ZstdHigh { 19 } else { 3 };
                self.packed = zstd::stream::encode_all(&self.flat[..], level)
                    .map_err(|e| Error::Io { path: self.name.clone(), source: e })?;
                &self.packed
            }
        };
        let mut head = [0u8; 8];
        head[4..].copy_from_slice(&(body.len() as u32).to_le_bytes());
        put(&mut self.writer, &mut self.position, &self.name, &head)?;
        put(&mut self.writer, &mut self.position, &self.name, body)?;
        self.pending.clear();
        Ok(())
    }

    /// Writes what is pending as a packet (if anything is) and flushes the writer: a live stream
    /// sends its packets as they are due.
    pub fn flush(&mut self) -> Result<()> {
        self.flush_packet()?;
        self.writer.flush().map_err(|e| Error::Io { path: self.name.clone(), source: e })
    }

    /// Writes what is pending and returns the writer.
    pub fn into_inner(mut self) -> Result<W> {
        self.flush()?;
        Ok(self.writer)
    }
}

impl<W: Write> Encoder<W> {
    /// Appends events; they must come in time order and lie inside the resolution.
    pub fn write(&mut self, events: &[Event]) -> Result<()> {
        for e in events {
            if e.t_us < self.last_t_us || !self.resolution.contains(e.x, e.y) {
                let at = Location::Byte(self.position);
                return Err(if e.t_us < self.last_t_us {
                    Error::TimestampBackwards { path: self.name.clone(), at, t_us: e.t_us, previous_us: self.last_t_us }
                } else {
                    Error::OutOfRange {
                        path: self.name.clone(),
                        at,
                        x: e.x as i64,
                        y: e.y as i64,
                        width: self.resolution.width,
                        height: self.resolution.height,
                    }
                });
            }
            self.last_t_us = e.t_us;
            self.pending.push(*e);
            if self.pending.len() == self.options.packet_events {
                self.flush_packet()?;
            }
        }
        Ok(())
    }
}

impl EventSink for Encoder<AtomicFile> {
    fn write(&mut self, events: &[Event]) -> Result<()> {
        Encoder::write(self, events)
    }
    fn finish(self: Box<Self>) -> Result<()> {
        self.into_inner()?.commit()
    }
}

fn put(writer: &mut impl Write, position: &mut u64, name: &std::path::Path, bytes: &[u8]) -> Result<()> {
    writer.write_all(bytes).map_err(|e| Error::Io { path: name.to_path_buf(), source: e })?;
    *position += bytes.len() as u64;
    Ok(())
}

/// The XML description DV writes for one event stream.
fn description(resolution: Resolution, options: &EncoderOptions) -> String {
    let source = xml_escape(&options.source);
    format!(
        r#"<dv version="2.0">
    <node name="outInfo" path="/mainloop/Recorder/outInfo/">
        <node name="0" path="/mainloop/Recorder/outInfo/0/">
            <attr key="compression" type="string">{compression}</attr>
            <attr key="originalModuleName" type="string">braille</attr>
            <attr key="originalOutputName" type="string">events</attr>
            <attr key="typeDescription" type="string">Array of events (polarity ON/OFF).</attr>
            <attr key="typeIdentifier" type="string">EVTS</attr>
            <node name="info" path="/mainloop/Recorder/outInfo/0/info/">
                <attr key="sizeX" type="int">{w}</attr>
                <attr key="sizeY" type="int">{h}</attr>
                <attr key="source" type="string">{source}</attr>
                <attr key="tsOffset" type="long">0</attr>
            </node>
        </node>
    </node>
</dv>
"#,
        compression = options.compression.dv_name(),
        w = resolution.width,
        h = resolution.height,
    )
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The `IOHeader` FlatBuffer (identifier `IOHE`): compression, no file data table, description.
fn io_header(compression: Compression, description: &str) -> Vec<u8> {
    let mut b = Vec::new();
    b.put_u32(24); // root table offset
    b.extend_from_slice(b"IOHE");
    // vtable at 8: its length, the table's length, then the three fields' offsets in the table
    for v in [10u16, 20, 4, 8, 16] {
        b.put_u16(v);
    }
    b.pad_to(8);
    // table at 24
    b.put_u32(24 - 8); // soffset to the vtable
    b.put_u32(compression.code() as u32);
    b.put_i64(-1); // file_data_position: no table of packets
    b.put_u32(44 - 40); // description: uoffset from here (40) to the string (44)
    b.put_u32(description.len() as u32);
    b.extend_from_slice(description.as_bytes());
    b.push(0);
    b.pad_to(8);
    b
}

/// A size-prefixed `EventPacket` FlatBuffer (identifier `EVTS`) holding `events`.
fn event_packet(events: &[Event], out: &mut Vec<u8>) {
    out.clear();
    out.reserve(32 + events.len() * EVENT_BYTES);
    let total = 32 + events.len() * EVENT_BYTES;
    out.put_u32((total - 4) as u32); // size prefix
    out.put_u32(16); // root offset, from byte 4 to the table at 20
    out.extend_from_slice(b"EVTS");
    for v in [6u16, 8, 4] {
        out.put_u16(v); // vtable at 12: its length, the table's length, field 0 at offset 4
    }
    out.pad_to(4);
    out.put_u32(20 - 12); // table at 20: soffset to the vtable
    out.put_u32(28 - 24); // elements: uoffset from here (24) to the vector (28)
    out.put_u32(events.len() as u32);
    for e in events {
        out.put_i64(e.t_us);
        out.extend_from_slice(&(e.x as i16).to_le_bytes());
        out.extend_from_slice(&(e.y as i16).to_le_bytes());
        out.extend_from_slice(&[e.polarity.is_on() as u8, 0, 0, 0]);
    }
}
