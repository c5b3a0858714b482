//! Text event streams, one event per line: `t_us,x,y,p` (microseconds, column, row, 1 = ON and
//! 0 or -1 = OFF).
//!
//! An optional header line names the columns in any order (`t_us`, `t` or `timestamp`; `x`; `y`;
//! `p`, `polarity` or `on`). Lines starting with `#` are comments; `# resolution: 640x480`
//! declares the sensor size, which the encoder writes and the decoder checks.

mod decoder;
mod encoder;

pub use decoder::Decoder;
pub use encoder::Encoder;

/// The header line the encoder writes.
pub const HEADER: &str = "t_us,x,y,p";
