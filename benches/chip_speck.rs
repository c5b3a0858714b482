//! The Speck character model (26 simulated RAB windows at 8 mm/s and 1.5 mm, one scan per row, 20
//! steps each) in Speck's arithmetic (8-bit weights, 16-bit membrane, several spikes per step;
//! stepped over every neuron of every core, and event-driven) against the floating-point engine
//! (stepped) on the same windows, one core. Throughput in windows per second: the fixed-point
//! engine's target is at most 1.5x the float engine's time. The work differs: in Speck's
//! arithmetic the neurons send several spikes per step (`braille eval chars --chip speck` gives
//! the SynOps of both).

use corpus::windows::{CharSetSpec, Task, build, snn_set};
use corpus::world::{TEST_SEED, World};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use experiments::eval::chars::CharModel;
use pipeline::models::Model;
use sim::BoardKind;
use snn::chip::xylo::Run;
use snn::engine::{Engine, Mode};
use std::hint::black_box;
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
    let engine = Engine::new(&model.network, model.config.dt_us, Mode::Stepped).unwrap();
    let chip = snn::chip::speck::map(&model.network).unwrap().spec.compile().unwrap();
    let mut group = c.benchmark_group("chip_speck");
    group.sample_size(10);
    group.throughput(Throughput::Elements(set.trains.len() as u64));
    let mut st = engine.state(0);
    group.bench_function("float_engine_stepped", |b| {
        b.iter(|| {
            for t in &set.trains {
                engine.run_train(&mut st, t).unwrap();
                black_box(st.output_counts(26));
            }
        })
    });
    for (name, run) in [("speck_stepped", Run::Stepped), ("speck_event_driven", Run::EventDriven)] {
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
