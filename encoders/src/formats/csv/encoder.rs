use super::HEADER;
use crate::error::{Error, Result};
use crate::event::{Event, Resolution};
use crate::formats::{AtomicFile, EventSink};
use std::io::Write;

/// Writes events as CSV: an optional `# resolution: WxH` comment, the header, one line per event.
pub struct Encoder<W: Write = AtomicFile> {
    writer: W,
    name: std::path::PathBuf,
    line: Vec<u8>,
}

impl Encoder<AtomicFile> {
    pub fn new(file: AtomicFile, resolution: Option<Resolution>) -> Result<Self> {
        let name = file.path().to_path_buf();
        Encoder::to_writer(file, &name, resolution)
    }
}

impl<W: Write> Encoder<W> {
    pub fn to_writer(mut writer: W, name: &std::path::Path, resolution: Option<Resolution>) -> Result<Self> {
        let err = |e| Error::Io { path: name.to_path_buf(), source: e };
        if let Some(r) = resolution {
            writeln!(writer, "# resolution: {r}").map_err(err)?;
        }
        writeln!(writer, "{HEADER}").map_err(err)?;
        Ok(Self { writer, name: name.to_path_buf(), line: Vec::with_capacity(64) })
    }

    pub fn write(&mut self, events: &[Event]) -> Result<()> {
        for e in events {
            self.line.clear();
            // Writing into a Vec cannot fail.
            let _ = writeln!(self.line, "{},{},{},{}", e.t_us, e.x, e.y, e.polarity.is_on() as u8);
            self.writer.write_all(&self.line).map_err(|e| Error::Io { path: self.name.clone(), source: e })?;
        }
        Ok(())
    }

    pub fn into_inner(mut self) -> Result<W> {
        self.writer.flush().map_err(|e| Error::Io { path: self.name.clone(), source: e })?;
        Ok(self.writer)
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
