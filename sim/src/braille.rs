//! Grade-1 Braille cells: the table lives in [`encoders::braille`], where the reader uses it too.

pub use encoders::braille::*;
