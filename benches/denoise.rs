//! The background-activity filter's cost per event (`encoders::denoise`): DV's lab chain
//! (2 ms, 1-8 neighbours, refractory 100 us) and dv-processing's filter, on a synthetic DVXplorer
//! stream of about 1 M events/s clustered as a sliding contact makes them.

mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use encoders::Resolution;
use encoders::denoise::{BackgroundActivityFilter, NoiseFilterSettings};
use std::hint::black_box;

fn denoise(c: &mut Criterion) {
    let events = common::dvxplorer_stream(1_000_000, 7);
    let mut group = c.benchmark_group("denoise");
    group.throughput(Throughput::Elements(events.len() as u64));
    group.sample_size(20);
    for (name, settings) in
        [("dv_lab", NoiseFilterSettings::DV_LAB), ("dv_processing", NoiseFilterSettings::DV_PROCESSING)]
    {
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut f = BackgroundActivityFilter::new(Resolution::DVXPLORER, settings).unwrap();
                black_box(events.iter().filter(|e| f.retain(e)).count())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, denoise);
criterion_main!(benches);
