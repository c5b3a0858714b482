//! The chip benches' comparison: a model on the float engine (stepped) and mapped into a chip's
//! arithmetic (`ChipModel::map`, global quantisation, the model's readout; stepped over every
//! neuron and event-driven, each sample with the chip's drain steps) on the same samples, one
//! core. Throughput in samples per second; #50's target for the chip is at most 1.5x the float
//! engine's time.

use criterion::{Criterion, Throughput};
use learn::data::SpikeSet;
use snn::chip::xylo::{Quantisation, Run};
use snn::chip::{Chip, ChipModel};
use snn::engine::{Engine, Mode};
use snn::model_file::SnnModel;
use std::hint::black_box;

/// Benchmarks group `group` (`float_engine_stepped`, `{prefix}_stepped`,
/// `{prefix}_event_driven`) on every sample of `set`.
pub fn against_float(
    c: &mut Criterion,
    group: &str,
    prefix: &str,
    sample_size: usize,
    model: &SnnModel,
    set: &SpikeSet,
    chip: Chip,
) {
    let engine = Engine::new(&model.network, model.config.dt_us, Mode::Stepped).unwrap();
    let mapped = ChipModel::map(&model.network, chip, Quantisation::Global, model.config.readout).unwrap().model;
    let mut group = c.benchmark_group(group);
    group.sample_size(sample_size);
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
    for (name, run) in [("stepped", Run::Stepped), ("event_driven", Run::EventDriven)] {
        group.bench_function(format!("{prefix}_{name}"), |b| {
            b.iter(|| {
                for t in &set.trains {
                    black_box(mapped.run_sample((0..t.n_steps()).map(|k| t.step(k)), run).unwrap());
                }
            })
        });
    }
    group.finish();
}
