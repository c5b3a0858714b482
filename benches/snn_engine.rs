//! The event-driven SNN engine (stepped mode, exactly the time-stepped network) on the peer
//! benchmark's network and input statistics: 2x60x80 input, 20 steps, 1.5% of pixels active per
//! step, batch 1, one core. Throughput is in synaptic events per second (stepped) and input events
//! per second (async).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use snn::engine::{Engine, Mode};
use snn::network::{peers_conv, random_input};
use std::hint::black_box;

fn samples(n_inputs: usize) -> Vec<Vec<(i64, u32)>> {
    (0..32u64)
        .map(|seed| {
            let x = random_input(1000 + seed, 20, n_inputs, 0.0075);
            (0..20 * n_inputs)
                .filter(|&k| x[k] != 0.0)
                .map(|k| ((k / n_inputs) as i64 * 1_000 + 10, (k % n_inputs) as u32))
                .collect()
        })
        .collect()
}

fn engine(c: &mut Criterion) {
    // gain 7.5: about 330 k synaptic events per sample, the peers' 328 k
    let net = peers_conv(1, 7.5);
    let engine = Engine::new(&net, 1_000, Mode::Stepped).unwrap();
    let inputs = samples(net.n_inputs());
    let mut st = engine.state(0);
    let mut synops = 0;
    for s in &inputs {
        engine.reset(&mut st, 0);
        for &(t, i) in s {
            engine.push(&mut st, t, i, 1.0).unwrap();
        }
        engine.finish(&mut st, 20_000);
        synops += st.stats.synops;
    }
    let mut group = c.benchmark_group("snn_engine");
    group.sample_size(20);
    group.throughput(Throughput::Elements(synops));
    group.bench_function("peers_conv_32_samples_stepped", |b| {
        b.iter(|| {
            for s in &inputs {
                engine.reset(&mut st, 0);
                for &(t, i) in s {
                    engine.push(&mut st, t, i, 1.0).unwrap();
                }
                engine.finish(&mut st, 20_000);
            }
            black_box(st.output.len())
        })
    });
    group.finish();
}

/// Async mode: every input event is processed to the end (each spike it causes, through every
/// layer) before the next is handed in, so time per input event is the per-event latency's mean;
/// `braille bench --json` gives its p50 and p99, timed event by event.
fn engine_async(c: &mut Criterion) {
    let net = peers_conv(1, 7.5);
    let engine = Engine::new(&net, 1_000, Mode::Async).unwrap();
    let inputs = samples(net.n_inputs());
    let events: u64 = inputs.iter().map(|s| s.len() as u64).sum();
    let mut st = engine.state(0);
    let mut group = c.benchmark_group("snn_engine");
    group.sample_size(20);
    group.throughput(Throughput::Elements(events));
    group.bench_function("peers_conv_32_samples_async_input_events", |b| {
        b.iter(|| {
            for s in &inputs {
                engine.reset(&mut st, 0);
                for &(t, i) in s {
                    engine.push(&mut st, t, i, 1.0).unwrap();
                }
            }
            black_box(st.output.len())
        })
    });
    group.finish();
}

criterion_group!(benches, engine, engine_async);
criterion_main!(benches);
