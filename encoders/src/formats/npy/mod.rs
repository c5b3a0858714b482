//! NumPy `.npy` structured arrays in Tonic's layout: fields `x, y, t, p` (`t` in microseconds),
//! loadable with `numpy.load` and usable by Tonic's transforms.
//!
//! The encoder writes `[('x', '<u2'), ('y', '<u2'), ('t', '<i8'), ('p', '|u1')]`. The decoder
//! reads any field order and the integer or boolean types NumPy and Tonic use.

mod decoder;
mod encoder;

pub use decoder::Decoder;
pub use encoder::Encoder;

/// The 6 bytes every `.npy` file starts with.
pub const MAGIC: &[u8] = b"\x93NUMPY";

/// The dtype the encoder writes.
pub const DESCR: &str = "[('x', '<u2'), ('y', '<u2'), ('t', '<i8'), ('p', '|u1')]";
