//! The raw1350 twin (iCub raw1350 test split, 270 samples of 193 steps; 24 inputs, 256 recurrent
//! CubaLIF with a bias, 27 leaky integrators) in Loihi 2's arithmetic (Lava's fixed-point LIF: 24-bit state, 8-bit
//! weights, 12-bit decays; stepped over every neuron, and event-driven; each sample with the two
//! latency steps) against the floating-point engine (stepped) on the same samples, one core.
//! Throughput in samples per second: the fixed-point engine's target is at most 1.5x the float
//! engine's time.

#[path = "common/chips.rs"]
mod chips;

use criterion::{Criterion, criterion_group, criterion_main};
use experiments::eval::tactile::{SplitChoice, encoding_of, load_split};
use snn::chip::Chip;
use std::path::Path;

fn chip(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("models/icub/nir/snn-raw1350.safetensors");
    let model = pipeline::models::load_snn(&path).unwrap();
    let enc = encoding_of(&model, &path).unwrap();
    let set = load_split(&root.join("data/icub_braille/raw1350"), &enc, SplitChoice::Test).unwrap();
    chips::against_float(c, "chip_loihi2", "loihi2", 10, &model, &set, Chip::Loihi2);
}

criterion_group!(benches, chip);
criterion_main!(benches);
