//! The engine's benchmark on the peer benchmark's network and input statistics (2x60x80 ON/OFF
//! input, 20 steps of 1 ms, 1.5% of inputs active per step), batch 1, one core; and a BPTT
//! training step of that network on burn (`braille bench`). Peer figures are those of the shared
//! peer benchmark (`scripts/peers/compare.sh` measures them side by side in one run).

use crate::error::Result;
use crate::peak_rss_mb;
use serde::Serialize;
use snn::engine::{Engine, Mode};
use snn::network::{peers_conv, random_input};
use std::time::Instant;

/// A training step's time and memory.
#[derive(Debug, Clone, Serialize)]
pub struct TrainReport {
    pub network: &'static str,
    pub batch: usize,
    pub steps: usize,
    pub ms_per_train_step: f64,
    pub ms_per_train_step_min: f64,
    pub peak_rss_mb: Option<f64>,
    pub peer_pytorch_ms: f64,
    pub peer_snntorch_ms: f64,
    pub peer_norse_ms: f64,
}

/// A training step of the peer network on burn: forward over 20 steps, BPTT, Adam.
pub fn train_step(batch: usize, repeats: usize) -> Result<TrainReport> {
    use burn::optim::{AdamConfig, GradientsParams};
    use burn::tensor::{Device, Int, Tensor, TensorData};
    use learn::snn::{SnnParams, SnnTwin};
    use snn::model_file::Readout;
    use snn::neuron::Surrogate;
    let net = peers_conv(1, 1.0);
    let spec = net.spec();
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 25.0 }, Readout::SpikeCount)?;
    let device = Device::flex().autodiff();
    let mut params = SnnParams::from_weights(&spec, &net.weights(), &device)?;
    let mut optim = AdamConfig::new().init();
    let loss_fn = burn::nn::loss::CrossEntropyLossConfig::new().init(&device);
    let (b, n) = (batch.max(1), net.n_inputs());
    let mut times = Vec::new();
    for rep in 0..repeats.max(1) + 2 {
        let input: Vec<Tensor<2>> = (0..STEPS)
            .map(|t| {
                let x = random_input(rep as u64 * 100 + t as u64, 1, b * n, 0.015);
                Tensor::<2>::from_data(TensorData::new(x, [b, n]), &device)
            })
            .collect();
        let y: Vec<i64> = (0..b as i64).map(|i| i % 26).collect();
        let y = Tensor::<1, Int>::from_data(TensorData::new(y, [b]), &device);
        let start = Instant::now();
        let out = twin.forward(&params, &input);
        let loss = loss_fn.forward(out.logits, y);
        let grads = GradientsParams::from_grads(loss.backward(), &params);
        params = optim.step(1e-3, params, grads);
        if rep >= 2 {
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    times.sort_by(f64::total_cmp);
    Ok(TrainReport {
        network: "peers conv SNN (as `braille bench`), rate-coded cross-entropy, fast-sigmoid surrogate",
        batch: b,
        steps: STEPS,
        ms_per_train_step: times[times.len() / 2],
        ms_per_train_step_min: times[0],
        peak_rss_mb: peak_rss_mb(),
        peer_pytorch_ms: 59.6,
        peer_snntorch_ms: 97.1,
        peer_norse_ms: 78.1,
    })
}

/// The weight scale that gives the peers' work per sample (about 330 k synaptic events).
pub const PEER_GAIN: f32 = 7.5;
pub const STEPS: usize = 20;
pub const DT_US: i64 = 1_000;

/// The engine on the peer benchmark.
#[derive(Debug, Clone, Serialize)]
pub struct EngineReport {
    pub network: &'static str,
    pub mode: &'static str,
    pub samples: u64,
    pub input_events_per_sample: f64,
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    /// Neuron state updates, the steps caught up lazily included.
    pub neuron_updates_per_sample: f64,
    pub ms_per_sample: f64,
    pub us_per_input_event: f64,
    pub ns_per_synop: f64,
    pub peer_pytorch_ms_per_sample: f64,
    pub speedup_vs_pytorch: f64,
    pub speedup_vs_snntorch: f64,
    /// Async mode (a neuron fires the moment its membrane crosses threshold): the time from an
    /// input event handed in to all its effects done (every spike it causes, through every
    /// layer), per event, timed one by one (the clock's own cost, about 20 ns, included).
    pub async_event_latency_ns_p50: Option<f64>,
    pub async_event_latency_ns_p99: Option<f64>,
    pub async_event_latency_ns_max: Option<f64>,
    pub async_input_events_per_s: f64,
}

/// Per-event latency in async mode over the samples: (histogram, events per second untimed).
fn async_latency(
    net: &snn::network::Network,
    samples: &[Vec<(i64, u32)>],
) -> Result<(pipeline::classify::Histogram, f64, u64)> {
    let engine = Engine::new(net, DT_US, Mode::Async)?;
    let mut st = engine.state(0);
    let mut h = pipeline::classify::Histogram::default();
    let mut max = 0u64;
    for s in samples {
        engine.reset(&mut st, 0);
        for &(t, i) in s {
            let t0 = Instant::now();
            engine.push(&mut st, t, i, 1.0)?;
            let ns = t0.elapsed().as_nanos() as u64;
            max = max.max(ns);
            h.add(ns);
        }
    }
    // throughput without the per-event clock
    let start = Instant::now();
    let mut n = 0u64;
    for s in samples {
        engine.reset(&mut st, 0);
        for &(t, i) in s {
            engine.push(&mut st, t, i, 1.0)?;
        }
        n += s.len() as u64;
    }
    Ok((h, n as f64 / start.elapsed().as_secs_f64(), max))
}

/// Input events of one sample, `(t_us, input)`, in time order.
pub fn sample_events(seed: u64, n_inputs: usize) -> Vec<(i64, u32)> {
    let x = random_input(seed, STEPS, n_inputs, 0.0075);
    let mut ev = Vec::new();
    for t in 0..STEPS {
        for i in 0..n_inputs {
            if x[t * n_inputs + i] != 0.0 {
                ev.push((t as i64 * DT_US + 10, i as u32));
            }
        }
    }
    ev
}

/// The event-driven engine on the peer benchmark's network: `samples` random inputs, the median
/// of `repeats` passes (stepped mode), and per-event latency in async mode.
pub fn engine(samples: u64, repeats: usize) -> Result<EngineReport> {
    let net = peers_conv(1, PEER_GAIN);
    let engine = Engine::new(&net, DT_US, Mode::Stepped)?;
    let samples: Vec<Vec<(i64, u32)>> = (0..samples.max(1)).map(|s| sample_events(1000 + s, net.n_inputs())).collect();
    let (mut events, mut synops, mut spikes, mut updates) = (0u64, 0u64, 0u64, 0u64);
    let mut times = Vec::new();
    let mut st = engine.state(0);
    for rep in 0..repeats.max(1) + 1 {
        let start = Instant::now();
        for s in &samples {
            engine.reset(&mut st, 0);
            for &(t, i) in s {
                engine.push(&mut st, t, i, 1.0)?;
            }
            engine.finish(&mut st, STEPS as i64 * DT_US);
            if rep == 0 {
                events += st.stats.input_events;
                synops += st.stats.synops;
                spikes += st.stats.spikes.iter().sum::<u64>();
                updates += st.stats.neuron_updates;
            }
        }
        if rep > 0 {
            times.push(start.elapsed().as_secs_f64());
        }
    }
    times.sort_by(f64::total_cmp);
    let n = samples.len() as f64;
    let per_sample = times[times.len() / 2] / n;
    let (latency, async_rate, async_max) = async_latency(&net, &samples)?;
    Ok(EngineReport {
        network: "peers conv SNN: 2x60x80 -> conv5x5s2(8) -> LIF -> conv3x3s2(16) -> LIF -> dense(26) -> LIF, 20 steps, 1.5% input",
        mode: "event-driven, stepped (exactly the time-stepped network)",
        samples: samples.len() as u64,
        input_events_per_sample: events as f64 / n,
        synops_per_sample: synops as f64 / n,
        spikes_per_sample: spikes as f64 / n,
        neuron_updates_per_sample: updates as f64 / n,
        ms_per_sample: per_sample * 1e3,
        us_per_input_event: per_sample * 1e6 / (events as f64 / n),
        ns_per_synop: per_sample * 1e9 / (synops as f64 / n),
        peer_pytorch_ms_per_sample: 3.45,
        speedup_vs_pytorch: 3.45 / (per_sample * 1e3),
        speedup_vs_snntorch: 7.96 / (per_sample * 1e3),
        async_event_latency_ns_p50: latency.quantile_ns(0.5),
        async_event_latency_ns_p99: latency.quantile_ns(0.99),
        async_event_latency_ns_max: Some(async_max as f64),
        async_input_events_per_s: async_rate,
    })
}
