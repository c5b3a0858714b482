//! AEDAT4 decoding throughput, in events per second, for each compression.

mod common;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use encoders::formats::aedat4::{Compression, Decoder, Encoder, EncoderOptions};
use encoders::formats::{EventSource, OpenOptions};
use std::hint::black_box;
use std::io::Cursor;
use std::path::Path;

fn decode(c: &mut Criterion) {
    let events = common::dvxplorer_stream(2_000_000, 42);
    let mut group = c.benchmark_group("aedat4_decode");
    group.throughput(Throughput::Elements(events.len() as u64));
    group.sample_size(20);
    for compression in [Compression::None, Compression::Lz4, Compression::Zstd] {
        let options = EncoderOptions { compression, ..EncoderOptions::default() };
        let mut enc = Encoder::to_writer(Vec::new(), Path::new("bench"), None, options).unwrap();
        enc.write(&events).unwrap();
        let bytes = enc.into_inner().unwrap();
        group.bench_with_input(BenchmarkId::from_parameter(format!("{compression:?}")), &bytes, |b, bytes| {
            b.iter(|| {
                let mut d =
                    Decoder::from_reader(Cursor::new(&bytes[..]), Path::new("bench"), &OpenOptions::default()).unwrap();
                let mut n = 0usize;
                let mut last = 0i64;
                while let Some(chunk) = d.next_chunk().unwrap() {
                    n += chunk.len();
                    last = chunk[chunk.len() - 1].t_us;
                }
                black_box((n, last))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, decode);
criterion_main!(benches);
