//! The few FlatBuffer reads and writes AEDAT4 needs, with every offset checked against the
//! buffer, so a corrupt packet gives an error instead of a panic or an out-of-bounds read.

/// A table inside a FlatBuffer.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Table<'a> {
    buf: &'a [u8],
    pos: usize,
    vtable: usize,
    vtable_len: usize,
}

fn u16_at(buf: &[u8], pos: usize) -> Result<u16, String> {
    buf.get(pos..pos + 2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .ok_or_else(|| format!("offset {pos} is past the end of a {}-byte buffer", buf.len()))
}

pub(crate) fn u32_at(buf: &[u8], pos: usize) -> Result<u32, String> {
    buf.get(pos..pos + 4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(|| format!("offset {pos} is past the end of a {}-byte buffer", buf.len()))
}

fn i64_at(buf: &[u8], pos: usize) -> Result<i64, String> {
    buf.get(pos..pos + 8)
        .map(|b| i64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
        .ok_or_else(|| format!("offset {pos} is past the end of a {}-byte buffer", buf.len()))
}

/// Follows a forward `uoffset` stored at `pos`.
fn follow(buf: &[u8], pos: usize) -> Result<usize, String> {
    let off = u32_at(buf, pos)? as usize;
    let target = pos.checked_add(off).filter(|&t| t < buf.len());
    target.ok_or_else(|| format!("offset at {pos} points to {}, past the end of the buffer", pos + off))
}

impl<'a> Table<'a> {
    /// The root table of `buf`, which starts with the root offset and a 4-byte identifier.
    pub fn root(buf: &'a [u8], identifier: &[u8; 4]) -> Result<Self, String> {
        let id = buf.get(4..8).ok_or("buffer too short for a FlatBuffer")?;
        if id != identifier {
            return Err(format!(
                "FlatBuffer identifier is {:?}, expected {:?}",
                String::from_utf8_lossy(id),
                String::from_utf8_lossy(identifier)
            ));
        }
        Self::at(buf, follow(buf, 0)?)
    }

    fn at(buf: &'a [u8], pos: usize) -> Result<Self, String> {
        let soffset = u32_at(buf, pos)? as i32 as i64;
        let vtable = pos as i64 - soffset;
        if vtable < 0 || vtable as usize + 4 > buf.len() {
            return Err(format!("table at {pos} has its vtable outside the buffer"));
        }
        let vtable = vtable as usize;
        let vtable_len = u16_at(buf, vtable)? as usize;
        if vtable_len < 4 || vtable + vtable_len > buf.len() {
            return Err(format!("vtable at {vtable} has an invalid length {vtable_len}"));
        }
        Ok(Self { buf, pos, vtable, vtable_len })
    }

    /// The position of field `index`, or `None` if the field is absent.
    fn field(&self, index: usize) -> Result<Option<usize>, String> {
        let slot = 4 + 2 * index;
        if slot + 2 > self.vtable_len {
            return Ok(None);
        }
        let off = u16_at(self.buf, self.vtable + slot)? as usize;
        Ok(if off == 0 { None } else { Some(self.pos + off) })
    }

    pub fn i32_or(&self, index: usize, default: i32) -> Result<i32, String> {
        match self.field(index)? {
            Some(p) => Ok(u32_at(self.buf, p)? as i32),
            None => Ok(default),
        }
    }

    pub fn i64_or(&self, index: usize, default: i64) -> Result<i64, String> {
        match self.field(index)? {
            Some(p) => i64_at(self.buf, p),
            None => Ok(default),
        }
    }

    pub fn string(&self, index: usize) -> Result<Option<&'a str>, String> {
        match self.vector(index, 1)? {
            Some(bytes) => std::str::from_utf8(bytes).map(Some).map_err(|e| format!("string is not UTF-8: {e}")),
            None => Ok(None),
        }
    }

    /// The bytes of vector field `index` whose elements are `element_bytes` wide.
    pub fn vector(&self, index: usize, element_bytes: usize) -> Result<Option<&'a [u8]>, String> {
        let Some(p) = self.field(index)? else { return Ok(None) };
        let start = follow(self.buf, p)?;
        let len = u32_at(self.buf, start)? as usize;
        let data = start + 4;
        let end = len.checked_mul(element_bytes).and_then(|b| b.checked_add(data));
        match end {
            Some(end) if end <= self.buf.len() => Ok(Some(&self.buf[data..end])),
            _ => Err(format!(
                "vector at {start} claims {len} elements of {element_bytes} bytes, past the end of a {}-byte buffer",
                self.buf.len()
            )),
        }
    }
}

/// Appends little-endian bytes.
pub(crate) trait PutLe {
    fn put_u16(&mut self, v: u16);
    fn put_u32(&mut self, v: u32);
    fn put_i64(&mut self, v: i64);
    fn pad_to(&mut self, align: usize);
}

impl PutLe for Vec<u8> {
    fn put_u16(&mut self, v: u16) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_u32(&mut self, v: u32) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_i64(&mut self, v: i64) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn pad_to(&mut self, align: usize) {
        while !self.len().is_multiple_of(align) {
            self.push(0);
        }
    }
}
