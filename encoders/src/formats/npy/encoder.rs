use super::{DESCR, MAGIC};
use crate::error::{Error, Result};
use crate::event::Event;
use crate::formats::{AtomicFile, EventSink};
use std::io::{Seek, SeekFrom, Write};

/// Bytes of the header the encoder writes (a multiple of 64, room for any 64-bit count).
const HEADER_BYTES: usize = 192;

/// Writes a structured `.npy` array. The element count is patched into the header at the end,
/// so events stream through without being held in memory.
pub struct Encoder<W: Write + Seek = AtomicFile> {
    writer: W,
    name: std::path::PathBuf,
    count: u64,
    record: Vec<u8>,
}

fn header(count: u64) -> Vec<u8> {
    let dict = format!("{{'descr': {DESCR}, 'fortran_order': False, 'shape': ({count},), }}");
    let mut h = MAGIC.to_vec();
    h.extend_from_slice(&[1, 0]);
    h.extend_from_slice(&((HEADER_BYTES - 10) as u16).to_le_bytes());
    h.extend_from_slice(dict.as_bytes());
    h.resize(HEADER_BYTES - 1, b' ');
    h.push(b'\n');
    h
}

impl Encoder<AtomicFile> {
    pub fn new(file: AtomicFile) -> Result<Self> {
        let name = file.path().to_path_buf();
        Encoder::to_writer(file, &name)
    }
}

impl<W: Write + Seek> Encoder<W> {
    pub fn to_writer(mut writer: W, name: &std::path::Path) -> Result<Self> {
        writer.write_all(&header(0)).map_err(|e| Error::Io { path: name.to_path_buf(), source: e })?;
        Ok(Self { writer, name: name.to_path_buf(), count: 0, record: Vec::new() })
    }

    pub fn write(&mut self, events: &[Event]) -> Result<()> {
        self.record.clear();
        for e in events {
            self.record.extend_from_slice(&e.x.to_le_bytes());
            self.record.extend_from_slice(&e.y.to_le_bytes());
            self.record.extend_from_slice(&e.t_us.to_le_bytes());
            self.record.push(e.polarity.is_on() as u8);
        }
        self.writer.write_all(&self.record).map_err(|e| Error::Io { path: self.name.clone(), source: e })?;
        self.count += events.len() as u64;
        Ok(())
    }

    /// Writes the final count into the header and returns the writer.
    pub fn into_inner(mut self) -> Result<W> {
        let err = |e| Error::Io { path: self.name.clone(), source: e };
        self.writer.seek(SeekFrom::Start(0)).map_err(err)?;
        self.writer.write_all(&header(self.count)).map_err(err)?;
        self.writer.seek(SeekFrom::End(0)).map_err(err)?;
        self.writer.flush().map_err(err)?;
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

#[cfg(test)]
mod tests {
    #[test]
    fn header_is_aligned_for_any_count() {
        for n in [0, 1, u64::MAX] {
            let h = super::header(n);
            assert_eq!(h.len(), super::HEADER_BYTES);
            assert_eq!(*h.last().unwrap(), b'\n');
            assert!(String::from_utf8_lossy(&h).contains(&format!("({n},)")));
        }
    }
}
