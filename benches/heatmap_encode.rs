//! Heat-map (paper eq. 4) and spike-train encoding throughput, in events per second.

mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use encoders::heatmap::{HeatmapConfig, HeatmapEncoder};
use encoders::spike_train::{SpikeTrainConfig, SpikeTrainEncoder};
use std::hint::black_box;

fn encode(c: &mut Criterion) {
    let events = common::dvxplorer_stream(2_000_000, 7);
    let span = events.last().unwrap().t_us + 1;
    let mut group = c.benchmark_group("encode");
    group.throughput(Throughput::Elements(events.len() as u64));
    group.sample_size(20);

    // The paper's configuration: 10 ms bins, 640x480 pooled by 4 to 160x120, ON and OFF.
    let hm = HeatmapEncoder::new(HeatmapConfig::default()).unwrap();
    let bins = (span as usize).div_ceil(10_000);
    let mut map = encoders::heatmap::Heatmap::zeros(0, 10_000, bins, hm.output());
    group.bench_function("heatmap_paper", |b| {
        b.iter(|| {
            map.counts.fill(0.0);
            hm.accumulate(black_box(&events), &mut map);
            black_box(map.counts[0])
        })
    });

    // 1 ms steps, 4x4 pooling of the DVXplorer
    let st = SpikeTrainEncoder::new(SpikeTrainConfig::default()).unwrap();
    let steps = (span as usize).div_ceil(1_000);
    group.bench_function("spike_train_1ms", |b| {
        b.iter(|| black_box(st.encode(black_box(&events), 0, steps).inputs.len()))
    });
    group.finish();
}

criterion_group!(benches, encode);
criterion_main!(benches);
