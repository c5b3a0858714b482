use super::MAGIC;
use crate::error::{Error, Location, Result, io_at};
use crate::event::{Event, Polarity};
use crate::formats::{CHUNK_EVENTS, Checker, EventSource, Format, OpenOptions, StreamInfo, io, read_up_to};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// An integer or boolean field type, as NumPy spells it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Bool,
    Signed(usize),
    Unsigned(usize),
}

impl Kind {
    fn parse(s: &str) -> Option<Kind> {
        let (order, code) = match s.as_bytes().first()? {
            b'<' | b'|' | b'=' => (true, &s[1..]),
            b'>' => (false, &s[1..]),
            _ => (true, s),
        };
        let kind = match code {
            "?" | "b1" => Kind::Bool,
            "i1" => Kind::Signed(1),
            "u1" => Kind::Unsigned(1),
            "i2" => Kind::Signed(2),
            "u2" => Kind::Unsigned(2),
            "i4" => Kind::Signed(4),
            "u4" => Kind::Unsigned(4),
            "i8" => Kind::Signed(8),
            "u8" => Kind::Unsigned(8),
            _ => return None,
        };
        // Big-endian multi-byte fields are not read.
        if !order && kind.bytes() > 1 {
            return None;
        }
        Some(kind)
    }

    fn bytes(self) -> usize {
        match self {
            Kind::Bool => 1,
            Kind::Signed(n) | Kind::Unsigned(n) => n,
        }
    }

    #[inline]
    fn read(self, b: &[u8]) -> i64 {
        let mut buf = [0u8; 8];
        let n = self.bytes();
        buf[..n].copy_from_slice(&b[..n]);
        match self {
            Kind::Bool => (b[0] != 0) as i64,
            Kind::Unsigned(_) => u64::from_le_bytes(buf).min(i64::MAX as u64) as i64,
            Kind::Signed(_) => {
                let shift = 64 - 8 * n as u32;
                (i64::from_le_bytes(buf) << shift) >> shift
            }
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Field {
    offset: usize,
    kind: Kind,
}

/// Streams events from a structured `.npy` array with fields `x, y, t, p`.
pub struct Decoder<R: Read = BufReader<File>> {
    path: PathBuf,
    reader: R,
    fields: [Field; 4],
    item_bytes: usize,
    remaining: u64,
    data_offset: u64,
    index: u64,
    info: StreamInfo,
    checker: Checker,
    raw: Vec<u8>,
    events: Vec<Event>,
}

impl Decoder {
    pub fn open(path: &Path, options: &OpenOptions) -> Result<Self> {
        let file = File::open(path).map_err(|e| io(path, e))?;
        Self::from_reader(BufReader::with_capacity(1 << 20, file), path, options)
    }
}

impl<R: Read> Decoder<R> {
    pub fn from_reader(mut reader: R, path: &Path, options: &OpenOptions) -> Result<Self> {
        let mut head = [0u8; 8];
        let n = read_up_to(&mut reader, &mut head).map_err(|e| io(path, e))?;
        if n == 0 {
            return Err(Error::Empty { path: path.into(), expected: "a NumPy .npy header".into() });
        }
        if n < 8 || &head[..6] != MAGIC {
            return Err(Error::BadMagic {
                path: path.into(),
                at: Location::Byte(0),
                format: "NumPy .npy",
                expected: "`\\x93NUMPY` and a version".into(),
                found: format!("{:?}", String::from_utf8_lossy(&head[..n])),
            });
        }
        let major = head[6];
        let len_bytes = match major {
            1 => 2,
            2 | 3 => 4,
            v => {
                return Err(Error::Unsupported {
                    path: path.into(),
                    what: format!("NumPy format version {v} (supported: 1, 2, 3)"),
                });
            }
        };
        let mut len = [0u8; 4];
        reader.read_exact(&mut len[..len_bytes]).map_err(|e| io_at(path, Location::Byte(8), "the header length", e))?;
        let header_len = u32::from_le_bytes(len) as u64;
        const MAX_HEADER: u64 = 1 << 20;
        if header_len > MAX_HEADER {
            return Err(Error::TooLarge {
                path: path.into(),
                at: Location::Byte(8),
                what: "the header",
                size: header_len,
                limit: MAX_HEADER,
            });
        }
        let start = 8 + len_bytes as u64;
        let mut header = Vec::new();
        (&mut reader).take(header_len).read_to_end(&mut header).map_err(|e| io(path, e))?;
        if (header.len() as u64) < header_len {
            return Err(Error::Truncated {
                path: path.into(),
                at: Location::Byte(start + header.len() as u64),
                expected: format!("a {header_len}-byte header"),
            });
        }
        let header = String::from_utf8_lossy(&header).into_owned();
        let bad = |what: String| Error::Corrupt { path: path.into(), at: Location::Byte(start), what };
        let (fields, item_bytes, count) = parse_header(&header).map_err(bad)?;
        Ok(Self {
            path: path.into(),
            reader,
            fields,
            item_bytes,
            remaining: count,
            data_offset: start + header_len,
            index: 0,
            info: StreamInfo { format: Format::Npy, resolution: options.resolution, source: None },
            checker: Checker::new(path, options.resolution),
            raw: Vec::new(),
            events: Vec::with_capacity(CHUNK_EVENTS),
        })
    }
}

/// Parses the header dict: the fields `x, y, t, p`, the item size and the element count.
fn parse_header(h: &str) -> Result<([Field; 4], usize, u64), String> {
    if !h.contains("'fortran_order': False") && !h.contains("\"fortran_order\": False") {
        return Err("only C-order arrays are read ('fortran_order': False)".into());
    }
    let descr_start = h.find("'descr':").ok_or("header has no 'descr'")? + 8;
    let rest = h[descr_start..].trim_start();
    if !rest.starts_with('[') {
        return Err(format!(
            "'descr' is not a structured dtype (a list of fields): {}",
            rest.split(',').next().unwrap_or("")
        ));
    }
    // The list ends at the bracket that closes it.
    let mut depth = 0;
    let mut end = None;
    for (i, c) in rest.char_indices() {
        match c {
            '[' | '(' => depth += 1,
            ']' | ')' => {
                depth -= 1;
                if depth == 0 {
                    end = Some(i);
                    break;
                }
            }
            _ => {}
        }
    }
    let list = &rest[1..end.ok_or("unterminated 'descr'")?];
    // Each top-level tuple: its quoted strings are (title,) name..., type (the last one).
    let mut named: Vec<(Vec<String>, String)> = Vec::new();
    let mut depth = 0;
    let mut item = String::new();
    for c in list.chars() {
        match c {
            '(' => {
                depth += 1;
                item.push(c);
            }
            ')' => {
                depth -= 1;
                item.push(c);
                if depth == 0 {
                    let strings = quoted(&item);
                    if strings.len() < 2 {
                        return Err(format!("cannot read the field {item}"));
                    }
                    let ty = strings[strings.len() - 1].clone();
                    named.push((strings[..strings.len() - 1].to_vec(), ty));
                    item.clear();
                }
            }
            _ if depth > 0 => item.push(c),
            _ => {}
        }
    }
    let mut offset = 0;
    let mut found: [Option<Field>; 4] = [None; 4];
    let aliases: [&[&str]; 4] = [&["x"], &["y"], &["t", "ts", "timestamp", "t_us"], &["p", "polarity", "on"]];
    for (names, ty) in &named {
        let kind = Kind::parse(ty).ok_or_else(|| {
            format!("field {names:?} has type {ty:?}; supported: little-endian integers (i1..i8, u1..u8) and bool")
        })?;
        for (slot, alias) in aliases.iter().enumerate() {
            if found[slot].is_none() && names.iter().any(|n| alias.contains(&n.as_str())) {
                found[slot] = Some(Field { offset, kind });
            }
        }
        offset += kind.bytes();
    }
    let names = ["x", "y", "t", "p"];
    let mut fields = [Field { offset: 0, kind: Kind::Bool }; 4];
    for i in 0..4 {
        fields[i] =
            found[i].ok_or_else(|| format!("no field `{}` in the dtype (fields x, y, t, p are needed)", names[i]))?;
    }
    let shape_start = h.find("'shape':").ok_or("header has no 'shape'")? + 8;
    let shape = h[shape_start..].trim_start();
    let inner = shape.strip_prefix('(').and_then(|s| s.split(')').next()).ok_or("cannot read 'shape'")?;
    let dims: Vec<&str> = inner.split(',').map(str::trim).filter(|s| !s.is_empty()).collect();
    if dims.len() != 1 {
        return Err(format!("'shape' is ({inner}); a one-dimensional array is needed"));
    }
    let count: u64 = dims[0].parse().map_err(|_| format!("'shape' holds {:?}, not a count", dims[0]))?;
    Ok((fields, offset, count))
}

fn quoted(s: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        if c == '\'' || c == '"' {
            let mut v = String::new();
            for d in chars.by_ref() {
                if d == c {
                    break;
                }
                v.push(d);
            }
            out.push(v);
        }
    }
    out
}

impl<R: Read> EventSource for Decoder<R> {
    fn info(&self) -> &StreamInfo {
        &self.info
    }

    fn next_chunk(&mut self) -> Result<Option<&[Event]>> {
        self.events.clear();
        if self.remaining == 0 {
            return Ok(None);
        }
        let n = self.remaining.min(CHUNK_EVENTS as u64) as usize;
        let bytes = n * self.item_bytes;
        self.raw.resize(bytes, 0);
        let got = read_up_to(&mut self.reader, &mut self.raw).map_err(|e| io(&self.path, e))?;
        if got < bytes {
            return Err(Error::Truncated {
                path: self.path.clone(),
                at: Location::Byte(self.data_offset + self.index * self.item_bytes as u64 + got as u64),
                expected: format!("{} more events of {} bytes", self.remaining, self.item_bytes),
            });
        }
        let [fx, fy, ft, fp] = self.fields;
        for (i, r) in self.raw.chunks_exact(self.item_bytes).enumerate() {
            let x = fx.kind.read(&r[fx.offset..]);
            let y = fy.kind.read(&r[fy.offset..]);
            let t_us = ft.kind.read(&r[ft.offset..]);
            let on = fp.kind.read(&r[fp.offset..]) > 0;
            let at = Location::Byte(self.data_offset + (self.index + i as u64) * self.item_bytes as u64);
            self.checker.check(t_us, x, y, || at)?;
            self.events.push(Event { t_us, x: x as u16, y: y as u16, polarity: Polarity::from_on(on) });
        }
        self.index += n as u64;
        self.remaining -= n as u64;
        Ok(Some(&self.events))
    }

    fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_our_dtype_and_aedat_python_dtype() {
        let h = format!("{{'descr': {}, 'fortran_order': False, 'shape': (5,), }}", crate::formats::npy::DESCR);
        let (f, size, n) = parse_header(&h).unwrap();
        assert_eq!((size, n), (13, 5));
        assert_eq!(f[2].offset, 4);
        let h = "{'descr': [('t', '<u8'), ('x', '<u2'), ('y', '<u2'), (('p', 'on'), '?')], 'fortran_order': False, 'shape': (3,), }";
        let (f, size, _) = parse_header(h).unwrap();
        assert_eq!(size, 13);
        assert_eq!((f[0].offset, f[3].offset, f[3].kind), (8, 12, Kind::Bool));
    }

    #[test]
    fn signed_fields_sign_extend() {
        assert_eq!(Kind::Signed(2).read(&(-3i16).to_le_bytes()), -3);
        assert_eq!(Kind::Unsigned(2).read(&(65535u16).to_le_bytes()), 65535);
    }

    #[test]
    fn unsupported_dtypes_are_named() {
        let h = "{'descr': [('x', '<f4'), ('y', '<u2'), ('t', '<i8'), ('p', '|u1')], 'fortran_order': False, 'shape': (1,), }";
        assert!(parse_header(h).unwrap_err().contains("'<f4'") || parse_header(h).unwrap_err().contains("<f4"));
    }
}
