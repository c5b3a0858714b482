//! The Xylo model (iCub raw1350 test split, 70 samples of 193 steps) in Xylo's arithmetic
//! (16-bit state, 8-bit weights, bit-shift decays; stepped as XyloSim loops, and event-driven)
//! against the floating-point engine (stepped) on the same samples, one core. Throughput in
//! samples per second: the fixed-point engine's target is at most 1.5x the float engine's time.

#[path = "common/chips.rs"]
mod chips;

use criterion::{Criterion, criterion_group, criterion_main};
use experiments::eval::tactile::{SplitChoice, encoding_of, load_split};
use snn::chip::Chip;
use std::path::Path;

fn chip(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("models/icub/chip/xylo-braille7.safetensors");
    let model = pipeline::models::load_snn(&path).unwrap();
    let enc = encoding_of(&model, &path).unwrap();
    let set = load_split(&root.join("data/icub_braille/raw1350"), &enc, SplitChoice::Test).unwrap();
    chips::against_float(c, "chip_xylo", "xylo", 20, &model, &set, Chip::Xylo);
}

criterion_group!(benches, chip);
criterion_main!(benches);
