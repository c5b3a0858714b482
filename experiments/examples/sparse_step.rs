//! The sparse trainer's step alone on the peer network and input of `braille bench --train`
//! (batch 32, the same batches), for profiling it without burn's step beside it:
//!
//! ```sh
//! cargo build --release -p experiments --example sparse_step
//! RAYON_NUM_THREADS=1 perf record target/release/examples/sparse_step 0 40   # exact, 40 steps
//! target/release/examples/sparse_step 0.01 30                                # truncated
//! ```
//!
//! Prints the median and fastest step, the median of Adam's update within it, the squared norm of
//! the first batch's gradient and a checksum of the weights after the last step (the same digits
//! before and after a change that keeps the arithmetic, and on any number of threads).

use experiments::bench::engine::{PEER_GAIN, STEPS, peer_train_batch};
use learn::sparse::{Adam, SparseSnn, StepEvents};
use snn::model_file::Readout;
use snn::network::peers_conv;
use snn::neuron::Surrogate;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let cutoff: f32 = args.next().map_or(Ok(0.0), |s| s.parse())?;
    let steps: usize = args.next().map_or(Ok(20), |s| s.parse())?;
    let net = peers_conv(1, PEER_GAIN);
    let trainer = SparseSnn::new(net.spec(), Surrogate::FastSigmoid { slope: 25.0 }, Readout::SpikeCount, cutoff)?;
    let batches: Vec<Vec<StepEvents>> = (0..4)
        .map(|rep| {
            let batch = peer_train_batch(7 + rep, 32, 0.015);
            batch.into_iter().map(|mut e| trainer.input_events(StepEvents::from_entries(STEPS, &mut e))).collect()
        })
        .collect();
    let labels: Vec<usize> = (0..32).map(|i| i % 26).collect();
    let mut params = trainer.params(&net.weights())?;
    let mut adam = Adam::new(&params, 0.0, 0.0);
    let (mut times, mut adam_ms, mut norm) = (Vec::new(), Vec::new(), 0.0);
    for step in 0..steps.max(1) {
        let samples: Vec<(&StepEvents, usize)> = batches[step % 4].iter().zip(labels.iter().copied()).collect();
        let start = Instant::now();
        let g = trainer.batch_gradient(&params, &samples, &[]);
        let update = Instant::now();
        adam.step(&mut params, &g.grads, 1e-6);
        adam_ms.push(update.elapsed().as_secs_f64() * 1e3);
        times.push(start.elapsed().as_secs_f64() * 1e3);
        if step == 0 {
            norm = g.grads.tensors().flatten().map(|&x| f64::from(x) * f64::from(x)).sum();
        }
    }
    times.sort_by(f64::total_cmp);
    adam_ms.sort_by(f64::total_cmp);
    // FNV-1a over the weights' bits
    let weights = params
        .tensors()
        .flatten()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, x| (h ^ u64::from(x.to_bits())).wrapping_mul(0x100_0000_01b3));
    println!(
        "cutoff {cutoff}: median {:.2} ms, fastest {:.2} ms, Adam's update {:.3} ms (median), |g|^2 {norm:e}, weights after {weights:016x}",
        times[times.len() / 2],
        times[0],
        adam_ms[adam_ms.len() / 2]
    );
    Ok(())
}
