//! Fuzzes the aedat4 decoder (see `common.rs`).
#![no_main]

mod common;

use encoders::formats::OpenOptions;
use libfuzzer_sys::fuzz_target;
use std::io::Cursor;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    common::drain(encoders::formats::aedat4::Decoder::from_reader(Cursor::new(data), Path::new("fuzz.aedat4"), &OpenOptions::default()));
});
