//! The raw1350 twin (iCub raw1350 test split, 270 samples of 193 steps; 24 inputs, 256 CubaLIF,
//! 27 leaky integrators) in Loihi 2's arithmetic (Lava's fixed-point LIF: 24-bit state, 8-bit
//! weights, 12-bit decays; stepped over every neuron, and event-driven; each sample with the two
//! latency steps) against the floating-point engine (stepped) on the same samples, one core.
//! Throughput in samples per second: the fixed-point engine's target is at most 1.5x the float
//! engine's time.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use experiments::eval::tactile::{SplitChoice, encoding_of, load_split};
use snn::chip::loihi2;
use snn::chip::xylo::Run;
use snn::engine::{Engine, Mode};
use std::hint::black_box;
use std::path::Path;

fn chip(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("models/icub/nir/snn-raw1350.safetensors");
    let model = pipeline::models::load_snn(&path).unwrap();
    let enc = encoding_of(&model, &path).unwrap();
    let set = load_split(&root.join("data/icub_braille/raw1350"), &enc, SplitChoice::Test).unwrap();
    let engine = Engine::new(&model.network, model.config.dt_us, Mode::Stepped).unwrap();
    let chip = loihi2::map(&model.network, model.config.readout).unwrap().spec.compile().unwrap();
    let mut group = c.benchmark_group("chip_loihi2");
    group.sample_size(10);
    group.throughput(Throughput::Elements(set.trains.len() as u64));
    let mut st = engine.state(0);
    group.bench_function("float_engine_stepped", |b| {
        b.iter(|| {
            for t in &set.trains {
                engine.run_train(&mut st, t).unwrap();
                black_box(st.output_v_max());
            }
        })
    });
    for (name, run) in [("loihi2_stepped", Run::Stepped), ("loihi2_event_driven", Run::EventDriven)] {
        group.bench_function(name, |b| {
            b.iter(|| {
                for t in &set.trains {
                    black_box(chip.run_sample((0..t.n_steps()).map(|k| t.step(k)), run).unwrap());
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, chip);
criterion_main!(benches);
