//! The Speck character model (26 simulated RAB windows at 8 mm/s and 1.5 mm, one scan per row, 20
//! steps each) in Speck's arithmetic (8-bit weights, 16-bit membrane, several spikes per step;
//! stepped over every neuron of every core, and event-driven) against the floating-point engine
//! (stepped) on the same windows, one core. Throughput in windows per second: the fixed-point
//! engine's target is at most 1.5x the float engine's time. The work differs: in Speck's
//! arithmetic the neurons send several spikes per step (`braille eval chars --chip speck` gives
//! the SynOps of both).

#[path = "common/chips.rs"]
mod chips;

use corpus::windows::{CharSetSpec, Task, build, snn_set};
use corpus::world::{TEST_SEED, World};
use criterion::{Criterion, criterion_group, criterion_main};
use experiments::eval::chars::CharModel;
use pipeline::models::Model;
use sim::BoardKind;
use snn::chip::Chip;
use std::path::Path;

fn chip(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("models/nominal/chip/speck-chars.safetensors");
    let m = CharModel::load(&path).unwrap();
    let Model::Snn(model) = &m.model else { panic!("the Speck model is an SNN") };
    let spec = CharSetSpec {
        boards: vec![BoardKind::Rab],
        speed_mm_s: 8.0,
        depth_mm: 1.5,
        trials: 1,
        seed: TEST_SEED,
        task: Task::Chars,
        jitter_ms: 0.0,
        world: World::test(sim::Realism::Nominal),
        blank_cells: false,
        sweep: None,
    };
    let (raw, _) = build(&spec, &m.input, &()).unwrap();
    let set = snn_set(&m.input, &raw, &(0..raw.len()).collect::<Vec<_>>(), model.config.dt_us, Task::Chars);
    chips::against_float(c, "chip_speck", "speck", 10, model, &set, Chip::Speck);
}

criterion_group!(benches, chip);
criterion_main!(benches);
