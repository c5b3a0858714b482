//! The ResNet baseline (lite preset, the shipped model's shape: 20 frames x ON/OFF x 64x80):
//! window inference at batch 1 on burn's CPU `flex` backend and on the folded path the reader
//! runs (`learn::resnet::folded`; on a dense window too, with its direct convolution and with
//! im2col throughout), and training throughput (windows per second: forward,
//! backward and Adam at batch 32, with the NormAug-free input) on burn.

use burn::tensor::Device;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use learn::resnet::{ImageSet, ResnetConfig};
use learn::train::{Silent, TrainConfig};
use rand::{Rng, SeedableRng};
use std::hint::black_box;

const SHAPE: [usize; 3] = [40, 64, 80];

/// Windows of sparse counts (about 2% of cells active, as in a character window).
fn windows(n: usize, seed: u64) -> ImageSet {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let size = SHAPE.iter().product::<usize>();
    ImageSet {
        shape: SHAPE,
        data: (0..n)
            .map(|_| {
                (0..size).map(|_| if rng.random_bool(0.02) { rng.random_range(1.0..4.0f32) } else { 0.0 }).collect()
            })
            .collect(),
        labels: (0..n).map(|i| i % 26).collect(),
    }
}

fn inference(c: &mut Criterion) {
    let cfg = ResnetConfig::lite(SHAPE, 26);
    let model = cfg.init(&Device::flex());
    let one = windows(1, 1);
    let mut group = c.benchmark_group("resnet");
    group.sample_size(30);
    group.throughput(Throughput::Elements(1));
    group.bench_function("lite_window_inference_batch1", |b| {
        b.iter(|| black_box(learn::resnet::evaluate(&model, &one, 1).1))
    });
    let folded = learn::resnet::folded::FoldedResnet::from_model(&cfg, &model).expect("folds");
    group.bench_function("lite_window_inference_batch1_folded", |b| {
        b.iter(|| black_box(folded.logits(&one.data[0]).expect("runs")))
    });
    // every cell non-zero: the dense work PyTorch does whatever the input (scripts/peers/resnet.sh),
    // with the direct convolution where the CPU has it, and with im2col and gemm throughout
    let dense: Vec<f32> =
        one.data[0].iter().enumerate().map(|(i, &v)| if v != 0.0 { v } else { 0.5 + (i % 7) as f32 * 0.1 }).collect();
    group.bench_function("lite_window_inference_batch1_folded_dense", |b| {
        b.iter(|| black_box(folded.logits(&dense).expect("runs")))
    });
    let im2col = folded.clone().with_direct_convolution(false);
    group.bench_function("lite_window_inference_batch1_folded_im2col_dense", |b| {
        b.iter(|| black_box(im2col.logits(&dense).expect("runs")))
    });
    group.finish();
}

fn training(c: &mut Criterion) {
    let cfg = ResnetConfig::lite(SHAPE, 26);
    let train = windows(64, 2);
    let val = windows(1, 3);
    let tc = TrainConfig { epochs: 1, batch_size: 32, lr: 1e-3, seed: 1, ..TrainConfig::default() };
    let identity = |img: &[f32], _: &mut rand_chacha::ChaCha8Rng| img.to_vec();
    let mut group = c.benchmark_group("resnet");
    group.sample_size(10);
    group.throughput(Throughput::Elements(train.len() as u64));
    group.bench_function("lite_training_64_windows_batch32", |b| {
        b.iter(|| {
            black_box(
                learn::resnet::train(&cfg, &train, &val, &tc, &identity, None, &mut Silent).expect("trains").1.len(),
            )
        })
    });
    group.finish();
}

criterion_group!(benches, inference, training);
criterion_main!(benches);
