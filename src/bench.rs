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
    ms_per_sample: f64,
    us_per_input_event: f64,
    ns_per_synop: f64,
    peer_pytorch_ms_per_sample: f64,
    speedup_vs_pytorch: f64,
    speedup_vs_snntorch: f64,
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
    let net = peers_conv(1, PEER_GAIN);
    let engine = Engine::new(&net, DT_US, Mode::Stepped)?;
    let samples: Vec<Vec<(i64, u32)>> =
        (0..args.samples.max(1)).map(|s| sample_events(1000 + s, net.n_inputs())).collect();
    let (mut events, mut synops, mut spikes) = (0u64, 0u64, 0u64);
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
            }
        }
        if rep > 0 {
            times.push(start.elapsed().as_secs_f64());
        }
    }
    times.sort_by(f64::total_cmp);
    let n = samples.len() as f64;
    let per_sample = times[times.len() / 2] / n;
    let r = Report {
        network: "peers conv SNN: 2x60x80 -> conv5x5s2(8) -> LIF -> conv3x3s2(16) -> LIF -> dense(26) -> LIF, 20 steps, 1.5% input",
        mode: "event-driven, stepped (exactly the time-stepped network)",
        samples: samples.len() as u64,
        input_events_per_sample: events as f64 / n,
        synops_per_sample: synops as f64 / n,
        spikes_per_sample: spikes as f64 / n,
        ms_per_sample: per_sample * 1e3,
        us_per_input_event: per_sample * 1e6 / (events as f64 / n),
        ns_per_synop: per_sample * 1e9 / (synops as f64 / n),
        peer_pytorch_ms_per_sample: 3.45,
        speedup_vs_pytorch: 3.45 / (per_sample * 1e3),
        speedup_vs_snntorch: 7.96 / (per_sample * 1e3),
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
    }
    Ok(())
}
