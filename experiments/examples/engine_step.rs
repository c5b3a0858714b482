//! The engine's stepped mode alone on the peer network and input of `braille bench` (the same
//! 64 samples), for profiling it and for timing a change against the build before it (the two
//! binaries alternated), without the async part beside it:
//!
//! ```sh
//! cargo build --release -p experiments --example engine_step
//! target/release/examples/engine_step 30                       # 30 passes over the samples
//! perf record target/release/examples/engine_step 60
//! ```
//!
//! Prints the fastest and median pass per sample, a checksum of the output spikes (the same
//! before and after a change that keeps the arithmetic), and the synaptic operations and neuron
//! updates per sample (what a change of schedule moves).

use experiments::bench::engine::{DT_US, PEER_GAIN, STEPS, sample_events};
use snn::engine::{Engine, Mode};
use snn::network::peers_conv;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let passes: usize = std::env::args().nth(1).map_or(Ok(20), |s| s.parse())?;
    let net = peers_conv(1, PEER_GAIN);
    let engine = Engine::new(&net, DT_US, Mode::Stepped)?;
    let samples: Vec<Vec<(i64, u32)>> = (0..64).map(|s| sample_events(1000 + s, net.n_inputs())).collect();
    let mut st = engine.state(0);
    let (mut times, mut checksum, mut updates, mut synops) = (Vec::new(), 0u64, 0u64, 0u64);
    for _ in 0..passes.max(1) {
        (checksum, updates, synops) = (0, 0, 0);
        let start = Instant::now();
        for s in &samples {
            engine.reset(&mut st, 0);
            for &(t, i) in s {
                engine.push(&mut st, t, i, 1.0)?;
            }
            engine.finish(&mut st, STEPS as i64 * DT_US);
            updates += st.stats.neuron_updates;
            synops += st.stats.synops;
            for (k, &(t, j)) in st.output.iter().enumerate() {
                checksum = checksum.wrapping_mul(31).wrapping_add(t as u64 ^ ((j as u64) << 32) ^ k as u64);
            }
        }
        times.push(start.elapsed().as_secs_f64() * 1e3 / samples.len() as f64);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "ms per sample: fastest {:.4}, median {:.4}; output checksum {checksum:016x}; per sample {} synaptic operations, {} neuron updates",
        times[0],
        times[times.len() / 2],
        synops / samples.len() as u64,
        updates / samples.len() as u64
    );
    Ok(())
}
