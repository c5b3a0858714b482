//! The virtual Evetac's speed: one 195 mm row at the default 640x480, on one core, at each
//! realism preset, at 8 mm/s (24.4 s of sliding, about 25 s with lowering, holds and lifting) and
//! at 32 mm/s (6.1 s of sliding). Target: 1/20 of sensor time or less (about 1.26 s at 8 mm/s).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sim::{Board, BoardKind, Realism, simulate};
use std::hint::black_box;

fn row(c: &mut Criterion) {
    let mut group = c.benchmark_group("simulator");
    group.sample_size(10);
    for realism in Realism::ALL {
        let setup = realism.setup();
        let board = Board::new(BoardKind::Sab, setup.geometry.clone(), Board::default_seed(&BoardKind::Sab)).unwrap();
        let sensor = setup.sensor(encoders::Resolution::DVXPLORER, 1).unwrap();
        for speed in [8.0, 32.0] {
            let scan = setup.scan(speed, 1.5, 0, 0);
            let events = simulate(&board, &sensor, &scan).unwrap().events.len() as u64;
            group.throughput(Throughput::Elements(events));
            group.bench_function(format!("sab_row0_{speed}mm_s_1.5mm_640x480_{realism}"), |b| {
                b.iter(|| black_box(simulate(&board, &sensor, &scan).unwrap().events.len()))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, row);
criterion_main!(benches);
