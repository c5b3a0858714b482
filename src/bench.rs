//! `braille bench`: the event-driven engine on the peer benchmark's network and input statistics
//! (2x60x80 ON/OFF input, 20 steps of 1 ms, 1.5% of inputs active per step), batch 1, one core.

use anyhow::Result;
use serde::Serialize;
use snn::engine::{Engine, Mode};
use snn::network::{peers_conv, random_input};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Samples (different random inputs) to run.
    #[arg(long, default_value_t = 64)]
    samples: u64,
    /// Repetitions over the samples; the median repetition is reported.
    #[arg(long, default_value_t = 7)]
    repeats: usize,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// Time a training step instead: batch 32, forward over the 20 steps, BPTT and Adam on burn.
    #[arg(long)]
    train: bool,
    /// Batch size of the training step.
    #[arg(long, default_value_t = 32)]
    batch: usize,
}

#[derive(Serialize)]
struct TrainReport {
    network: &'static str,
    batch: usize,
    steps: usize,
    ms_per_train_step: f64,
    ms_per_train_step_min: f64,
    peak_rss_mb: Option<f64>,
    peer_pytorch_ms: f64,
    peer_snntorch_ms: f64,
    peer_norse_ms: f64,
}

/// Peak resident memory of this process (Linux), in MB.
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// A training step of the peer network on burn: forward over 20 steps, BPTT, Adam.
fn run_train(args: &Args) -> Result<()> {
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
    let (b, n) = (args.batch.max(1), net.n_inputs());
    let mut times = Vec::new();
    for rep in 0..args.repeats.max(1) + 2 {
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
    let r = TrainReport {
        network: "peers conv SNN (as `braille bench`), rate-coded cross-entropy, fast-sigmoid surrogate",
        batch: b,
        steps: STEPS,
        ms_per_train_step: times[times.len() / 2],
        ms_per_train_step_min: times[0],
        peak_rss_mb: peak_rss_mb(),
        peer_pytorch_ms: 59.6,
        peer_snntorch_ms: 97.1,
        peer_norse_ms: 78.1,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        println!(
            "training step (batch {}, {} steps, BPTT + Adam on burn flex): {:.1} ms median, {:.1} ms best; peak RSS {:.0} MB; peers: PyTorch 59.6, snnTorch 97.1, Norse 78.1 ms",
            r.batch,
            r.steps,
            r.ms_per_train_step,
            r.ms_per_train_step_min,
            r.peak_rss_mb.unwrap_or(f64::NAN)
        );
    }
    Ok(())
}

/// The weight scale that gives the peers' work per sample (about 330 k synaptic events).
pub const PEER_GAIN: f32 = 7.5;
pub const STEPS: usize = 20;
pub const DT_US: i64 = 1_000;

#[derive(Serialize)]
struct Report {
    network: &'static str,
    mode: &'static str,
    samples: u64,
    input_events_per_sample: f64,
    synops_per_sample: f64,
    spikes_per_sample: f64,
    /// Neuron state updates, the steps caught up lazily included.
    neuron_updates_per_sample: f64,
    ms_per_sample: f64,
    us_per_input_event: f64,
    ns_per_synop: f64,
    peer_pytorch_ms_per_sample: f64,
    speedup_vs_pytorch: f64,
    speedup_vs_snntorch: f64,
    /// Async mode (a neuron fires the moment its membrane crosses threshold): the time from an
    /// input event handed in to all its effects done (every spike it causes, through every
    /// layer), per event, timed one by one (the clock's own cost, about 20 ns, included).
    async_event_latency_ns_p50: Option<f64>,
    async_event_latency_ns_p99: Option<f64>,
    async_event_latency_ns_max: Option<f64>,
    async_input_events_per_s: f64,
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

pub fn run(args: Args) -> Result<()> {
    if args.train {
        return run_train(&args);
    }
    let net = peers_conv(1, PEER_GAIN);
    let engine = Engine::new(&net, DT_US, Mode::Stepped)?;
    let samples: Vec<Vec<(i64, u32)>> =
        (0..args.samples.max(1)).map(|s| sample_events(1000 + s, net.n_inputs())).collect();
    let (mut events, mut synops, mut spikes, mut updates) = (0u64, 0u64, 0u64, 0u64);
    let mut times = Vec::new();
    let mut st = engine.state(0);
    for rep in 0..args.repeats.max(1) + 1 {
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
    let r = Report {
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
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        println!(
            "{:.3} ms per sample, {:.3} us per input event, {:.3} ns per synaptic event ({:.0} input events, {:.0} synops, {:.0} spikes per sample); {:.1}x PyTorch's 3.45 ms, {:.1}x snnTorch's 7.96 ms (their figures from the shared peer benchmark)",
            r.ms_per_sample,
            r.us_per_input_event,
            r.ns_per_synop,
            r.input_events_per_sample,
            r.synops_per_sample,
            r.spikes_per_sample,
            r.speedup_vs_pytorch,
            r.speedup_vs_snntorch
        );
        println!(
            "async mode: an input event's effects done in {:.0} ns (p50), {:.0} ns (p99), {:.0} ns at most; {:.2} M input events/s",
            r.async_event_latency_ns_p50.unwrap_or(f64::NAN),
            r.async_event_latency_ns_p99.unwrap_or(f64::NAN),
            r.async_event_latency_ns_max.unwrap_or(f64::NAN),
            r.async_input_events_per_s / 1e6
        );
    }
    Ok(())
}
