//! The virtual Evetac's speed: one 195 mm row at 8 mm/s (24.4 s of sliding, 25.2 s with lowering,
//! holds and lifting) at the default 640x480, on one core. Target: 1/20 of sensor time or less.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sim::{Board, BoardGeometry, BoardKind, CameraConfig, GelConfig, ScanConfig, Sensor, simulate};
use std::hint::black_box;

fn row(c: &mut Criterion) {
    let board = Board::new(BoardKind::Sab, BoardGeometry::default(), Board::default_seed(&BoardKind::Sab)).unwrap();
    let sensor = Sensor::new(CameraConfig::default(), GelConfig::default(), 1).unwrap();
    let scan = ScanConfig { speed_mm_s: 8.0, depth_mm: 1.5, ..ScanConfig::default() };
    let events = simulate(&board, &sensor, &scan).unwrap().events.len() as u64;
    let mut group = c.benchmark_group("simulator");
    group.sample_size(10);
    group.throughput(Throughput::Elements(events));
    group.bench_function("sab_row0_8mm_s_1.5mm_640x480", |b| {
        b.iter(|| black_box(simulate(&board, &sensor, &scan).unwrap().events.len()))
    });
    group.finish();
}

criterion_group!(benches, row);
criterion_main!(benches);
