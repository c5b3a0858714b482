//! The engine's benchmark on the peer benchmark's network and input statistics (2x60x80 ON/OFF
//! input, 20 steps of 1 ms, 1.5% of inputs active per step), batch 1, one core; and a BPTT
//! training step of that network (`braille bench --train`). No peer figure is written in here: a
//! ratio against a peer is measured in one run, like for like (`scripts/peers/compare.sh` runs the
//! shared peer benchmark, its layers without bias as ours, beside these at the same threads).

use crate::error::Result;
use serde::Serialize;
use snn::engine::{Engine, Mode};
use snn::network::peers_conv;
use std::time::Instant;

/// One trainer's training step: time and memory.
#[derive(Debug, Clone, Serialize)]
pub struct StepTiming {
    pub trainer: String,
    pub ms_per_train_step: f64,
    pub ms_per_train_step_min: f64,
    /// Peak RSS while this trainer ran (the process's peak restarted before it), MB.
    pub peak_rss_mb: Option<f64>,
}

/// A training step of the peer network with each trainer.
#[derive(Debug, Clone, Serialize)]
pub struct TrainReport {
    pub network: &'static str,
    /// Threads the trainers ran on (rayon's pool; `RAYON_NUM_THREADS` sets it).
    pub threads: usize,
    /// Median ms per training step with exact gradients (ours, cutoff 0): the like-for-like
    /// figure against a peer's autograd.
    pub ms_per_train_step_exact: f64,
    /// Median ms per training step of ours truncated at `gradient_cutoff` (an approximate
    /// gradient; `truncation_cosine` says how close on the first batch).
    pub ms_per_train_step_truncated: f64,
    /// Median ms per training step on burn (dense tensors, autodiff).
    pub ms_per_train_step_dense: f64,
    pub batch: usize,
    pub steps: usize,
    /// Share of the 60x80 pixels with an event per step (one polarity each), as the peers'.
    pub input_density: f64,
    /// burn flex, dense tensors (`--trainer dense`).
    pub dense: StepTiming,
    /// Ours, truncated at `gradient_cutoff` (the default `--trainer sparse`).
    pub sparse: StepTiming,
    /// Ours, exact (cutoff 0).
    pub sparse_exact: StepTiming,
    pub gradient_cutoff: f32,
    /// The truncated gradient against the exact one, on the first batch: cosine and relative L2
    /// error.
    pub truncation_cosine: f64,
    pub truncation_relative_error: f64,
    /// Share of neuron-steps of the spiking layers that keep a surrogate (the truncated backward
    /// works on these), first batch.
    pub kept_fraction: f64,
    /// Spikes per sample in each layer, first batch.
    pub spikes_per_sample: Vec<f64>,
    /// Spikes per neuron and step in each layer, first batch (the peers report theirs).
    pub spike_rate_per_layer: Vec<f64>,
}

/// The peers' training input: per step, `density` of the pixels have one event of a random
/// polarity; `(step, input, 1)` entries of each of `batch` samples (C order).
pub fn peer_train_batch(seed: u64, batch: usize, density: f64) -> Vec<learn::sparse::Entries> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let plane = 60 * 80;
    (0..batch)
        .map(|_| {
            let mut e = Vec::new();
            for t in 0..STEPS as u32 {
                for p in 0..plane as u32 {
                    if rng.random_bool(density) {
                        let pol = rng.random_bool(0.5) as u32;
                        e.push((t, pol * plane as u32 + p, 1.0));
                    }
                }
            }
            e
        })
        .collect()
}

/// The peers' learning rate in their timing: tiny, so that activity does not drift while timed
/// (Adam's cost does not depend on it).
const PEER_LR: f64 = 1e-6;

/// A training step of the peer network (forward over 20 steps, BPTT, Adam; spike-count
/// cross-entropy, fast-sigmoid surrogate of slope 25), weights at the peers' activity
/// ([`PEER_GAIN`]), input at their density: the median of `repeats` after two warm-ups, with
/// burn (dense) and with the sparse trainer at `cutoff` and exact.
pub fn train_step(batch: usize, repeats: usize, cutoff: f32) -> Result<TrainReport> {
    use learn::sparse::{Adam, SparseSnn, StepEvents};
    use snn::model_file::Readout;
    use snn::neuron::Surrogate;
    let net = peers_conv(1, PEER_GAIN);
    let spec = net.spec();
    let surrogate = Surrogate::FastSigmoid { slope: 25.0 };
    let b = batch.max(1);
    let density = 0.015;
    let batches: Vec<Vec<learn::sparse::Entries>> =
        (0..repeats.max(1) + 2).map(|rep| peer_train_batch(7 + rep as u64, b, density)).collect();
    let labels: Vec<usize> = (0..b).map(|i| i % 26).collect();
    let median = |mut t: Vec<f64>| {
        t.sort_by(f64::total_cmp);
        (t[t.len() / 2], t[0])
    };
    // ours
    let sparse_run = |cutoff: f32| -> Result<(StepTiming, learn::sparse::BatchGradient)> {
        crate::reset_peak_rss();
        let trainer = SparseSnn::new(spec.clone(), surrogate, Readout::SpikeCount, cutoff)?;
        let mut params = trainer.params(&net.weights())?;
        let mut adam = Adam::new(&params, 0.0, 0.0);
        let mut times = Vec::new();
        let mut first = None;
        for (rep, batch) in batches.iter().enumerate() {
            // the batch in the trainer's input form before the clock starts, as the peers' input
            // tensors are made before theirs (and as `braille train` encodes a dataset once);
            // one batch at a time, so that the memory figure holds one batch's input as before
            let events: Vec<StepEvents> =
                batch.iter().map(|e| trainer.input_events(StepEvents::from_entries(STEPS, &mut e.clone()))).collect();
            let start = Instant::now();
            let samples: Vec<(&StepEvents, usize)> = events.iter().zip(labels.iter().copied()).collect();
            let g = trainer.batch_gradient(&params, &samples, &[]);
            adam.step(&mut params, &g.grads, PEER_LR);
            if rep >= 2 {
                times.push(start.elapsed().as_secs_f64() * 1e3);
            }
            if rep == 0 {
                first = Some(g);
            }
        }
        let (ms, min) = median(times);
        let name = if cutoff > 0.0 { format!("sparse, cutoff {cutoff}") } else { "sparse, exact".into() };
        let timing = StepTiming {
            trainer: name,
            ms_per_train_step: ms,
            ms_per_train_step_min: min,
            peak_rss_mb: crate::peak_rss_mb(),
        };
        Ok((timing, first.expect("a first batch")))
    };
    let (sparse, cut_grad) = sparse_run(cutoff)?;
    let (sparse_exact, exact_grad) = sparse_run(0.0)?;
    let (truncation_cosine, truncation_relative_error) =
        learn::train::gradient_agreement(&cut_grad.grads, &exact_grad.grads);
    let neuron_steps: usize = net.layers.iter().map(|l| l.op.n_out()).sum::<usize>() * STEPS * b;
    let spikes_per_sample: Vec<f64> = exact_grad.spikes.iter().map(|s| s / b as f64).collect();
    let spike_rate_per_layer =
        spikes_per_sample.iter().zip(&net.layers).map(|(s, l)| s / (l.op.n_out() * STEPS) as f64).collect();
    // burn
    let dense = dense_train_step(&spec, &net.weights(), &batches, &labels)?;
    Ok(TrainReport {
        network: "peers conv SNN (as `braille bench`), rate-coded cross-entropy, fast-sigmoid surrogate",
        threads: rayon::current_num_threads(),
        ms_per_train_step_exact: sparse_exact.ms_per_train_step,
        ms_per_train_step_truncated: sparse.ms_per_train_step,
        ms_per_train_step_dense: dense.ms_per_train_step,
        batch: b,
        steps: STEPS,
        input_density: density,
        dense,
        sparse,
        sparse_exact,
        gradient_cutoff: cutoff,
        truncation_cosine,
        truncation_relative_error,
        kept_fraction: cut_grad.kept_surrogates as f64 / neuron_steps as f64,
        spikes_per_sample,
        spike_rate_per_layer,
    })
}

/// The same steps with burn's autodiff on dense tensors.
fn dense_train_step(
    spec: &snn::spec::NetworkSpec,
    weights: &[snn::spec::LayerWeights],
    batches: &[Vec<learn::sparse::Entries>],
    labels: &[usize],
) -> Result<StepTiming> {
    use burn::optim::{AdamConfig, GradientsParams};
    use burn::tensor::{Device, Int, Tensor, TensorData};
    use learn::snn::{SnnParams, SnnTwin};
    use snn::model_file::Readout;
    use snn::neuron::Surrogate;
    crate::reset_peak_rss();
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 25.0 }, Readout::SpikeCount)?;
    let device = Device::flex().autodiff();
    let mut params = SnnParams::from_weights(spec, weights, &device)?;
    let mut optim = AdamConfig::new().init();
    let loss_fn = burn::nn::loss::CrossEntropyLossConfig::new().init(&device);
    let n: usize = spec.input_shape.iter().product();
    let mut times = Vec::new();
    for (rep, batch) in batches.iter().enumerate() {
        let b = batch.len();
        // the input tensor made before the clock starts, as the peers' (and the sparse
        // trainer's), one batch at a time
        let input = learn::train::dense_input(batch, STEPS, n, &device);
        let start = Instant::now();
        let y: Vec<i64> = labels.iter().map(|&l| l as i64).collect();
        let y = Tensor::<1, Int>::from_data(TensorData::new(y, [b]), &device);
        let out = twin.forward(&params, &input);
        let loss = loss_fn.forward(out.logits, y);
        let grads = GradientsParams::from_grads(loss.backward(), &params);
        params = optim.step(PEER_LR, params, grads);
        if rep >= 2 {
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    times.sort_by(f64::total_cmp);
    Ok(StepTiming {
        trainer: "dense (burn flex, autodiff)".into(),
        ms_per_train_step: times[times.len() / 2],
        ms_per_train_step_min: times[0],
        peak_rss_mb: crate::peak_rss_mb(),
    })
}

pub use snn::network::{PEER_DT_US as DT_US, PEER_GAIN, PEER_STEPS as STEPS};

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
    /// Async mode (a neuron fires the moment its membrane crosses threshold): the time from an
    /// input event handed in to all its effects done (every spike it causes, through every
    /// layer), per event, timed one by one (the clock's own cost, about 20 ns, included).
    pub async_event_latency_ns_p50: Option<f64>,
    pub async_event_latency_ns_p99: Option<f64>,
    pub async_event_latency_ns_max: Option<f64>,
    pub async_input_events_per_s: f64,
    /// Stepped mode with 1 to N independent streams at once, one per thread, each its own state
    /// over the shared engine and every sample: the throughput of all streams together.
    pub streams: Vec<StreamsRow>,
    /// The host itself, in the same rounds as `streams`: 1 to N threads of arithmetic that
    /// touches no memory (vector multiply-adds held in registers), each row's speedup over one
    /// thread. Where two threads of it fall short of 2x, the host shares its cores in those
    /// rounds.
    pub register_loop: Vec<ThreadsRow>,
    /// The same for 1 to N threads each reading its own 1 MiB buffer by dependent loads (eight
    /// walks at once), which the second-level cache serves: where two threads of it fall short
    /// of 2x, the host shares the caches the streams' state lives in.
    pub cache_loop: Vec<ThreadsRow>,
}

/// [`EngineReport::register_loop`] and [`EngineReport::cache_loop`]: `threads` threads at once.
#[derive(Debug, Clone, Serialize)]
pub struct ThreadsRow {
    pub threads: usize,
    /// The median round's wall time (the slowest thread's).
    pub ms_per_round: f64,
    /// Their work per second over one thread's, measured in the same call.
    pub speedup: f64,
}

/// The peer benchmark with `streams` streams at once (stepped mode).
#[derive(Debug, Clone, Serialize)]
pub struct StreamsRow {
    pub streams: usize,
    /// Samples finished per second, all streams together (median of the repetitions' walls).
    pub samples_per_s: f64,
    /// Over one stream's `samples_per_s`, measured in the same call.
    pub speedup: f64,
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

pub use snn::network::peer_sample as sample_events;

/// Runs every sample through `engine` on `st` (stepped mode), each from a reset.
fn run_samples(engine: &Engine, st: &mut snn::engine::EngineState, samples: &[Vec<(i64, u32)>]) -> Result<()> {
    for s in samples {
        engine.reset(st, 0);
        for &(t, i) in s {
            engine.push(st, t, i, 1.0)?;
        }
        engine.finish(st, STEPS as i64 * DT_US);
    }
    Ok(())
}

/// Samples each stream runs untimed before each timed round of [`stream_scaling`] (an eighth of
/// the default 64), so that a round starts in warm caches, as a stream that runs on finds them:
/// the entry before left the caches to other work (the cache probe walks 1 MiB per thread).
/// Without it the first samples of each round fetched the engine's lists and weights from the
/// third-level cache: `braille bench --json --streams 2` measured the time per sample about 4%
/// longer (eight runs alternated with and without, median paired ratio 0.96; 2026-12-04).
const WARM_SAMPLES: usize = 8;

/// What a bench thread runs in one entry of [`stream_scaling`]'s plan.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Work {
    /// Every sample through the engine, from a reset each.
    Engine,
    /// [`register_work`]: arithmetic that touches no memory.
    Registers,
    /// [`cache_work`]: loads from the thread's own cache-sized buffer.
    Cache,
}

/// Every kind of [`Work`], in the order each round runs them.
const WORKS: [Work; 3] = [Work::Engine, Work::Registers, Work::Cache];

/// Steps of [`register_work`] per call: 12.3 ms a round on one thread of the machine of
/// 2026-12-04 (AMD EPYC, AVX2), about as long as a round of the engine's 64 samples at one stream
/// (13 ms), so that both are as exposed to the host's interruptions.
const REGISTER_ITERATIONS: u64 = 6_000_000;

/// Arithmetic that touches no memory: twelve independent chains of multiplies and adds, eight
/// lanes each, held in vector registers (`iterations` steps of each). Two free cores run two
/// threads of it in the time of one; two hardware threads of one core, or cores the hypervisor
/// shares, take longer. Returns a sum of the lanes, so that nothing is optimised away.
fn register_work(iterations: u64) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: this CPU has AVX2 (just checked).
        return unsafe { register_work_avx2(iterations) };
    }
    register_work_with(iterations)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn register_work_avx2(iterations: u64) -> f32 {
    register_work_with(iterations)
}

#[inline(always)]
fn register_work_with(iterations: u64) -> f32 {
    let mut a = [[0f32; 8]; 12];
    for (j, a) in a.iter_mut().enumerate() {
        *a = [1.0 + j as f32 * 1e-3; 8];
    }
    let (m, c) = (std::hint::black_box(0.999_999_9f32), std::hint::black_box(1e-7f32));
    for _ in 0..iterations {
        for a in a.iter_mut() {
            for x in a.iter_mut() {
                *x = *x * m + c;
            }
        }
    }
    a.iter().map(|a| a[0]).sum()
}

/// Entries of each thread's buffer for [`cache_work`]: 1 MiB of `u32`, the size of a core's
/// second-level cache on the machine of 2026-12-04 (1 MiB a core; some of it spills to the
/// shared third level). Walked about once untimed before each timed round.
const CACHE_ENTRIES: usize = 1 << 18;

/// Steps of each of [`cache_work`]'s eight walks per call: 11.7 ms a round on one thread of that
/// machine, about as long as the engine's round.
const CACHE_STEPS: u64 = 1_500_000;

/// A random cycle through `n` entries: `next[i]` is the entry after `i` in a seeded shuffle of
/// them (taken as a ring), so following it from any entry visits all of them.
fn cache_cycle(n: usize, seed: u64) -> Vec<u32> {
    use rand::SeedableRng;
    use rand::seq::SliceRandom;
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
    let mut next = vec![0u32; n];
    for w in 0..n {
        next[order[w] as usize] = order[(w + 1) % n];
    }
    next
}

/// Memory the thread owns, read as fast as the caches serve it: eight independent walks through
/// the random cycle `next` ([`cache_cycle`]), `steps` steps each (each load's address is the last
/// load's value, so nothing can be fetched ahead). Two threads on two cores with private caches
/// take the time of one; where a core's caches are shared with other work, longer. Returns where
/// the walks ended, so that nothing is optimised away.
fn cache_work(next: &[u32], steps: u64) -> [u32; 8] {
    let n = next.len() as u32;
    let mut at: [u32; 8] = std::array::from_fn(|j| j as u32 * (n / 8));
    for _ in 0..steps {
        for a in at.iter_mut() {
            *a = next[*a as usize];
        }
    }
    at
}

/// 1 to `streams` streams at once, one per thread, each its own state through all the samples:
/// `repeats` rounds, each timing 1, 2, .. `streams` streams in turn (so that the machine's drift
/// hits every row alike), after one untimed round; per row the median round's wall time (the
/// slowest stream's: a barrier starts them together). Each round also times 1 to `streams`
/// threads of [`register_work`] and of [`cache_work`], so that the host's own scaling, on
/// arithmetic that touches no memory and on loads from a thread's own cache-sized buffer, stands
/// beside the engine's, measured in the same rounds. Before each timed entry its threads warm
/// their caches untimed ([`WARM_SAMPLES`] of the engine's samples; about one walk of the cache
/// probe's buffer).
///
/// The threads live through every round, as a server's workers would: a thread spawned per
/// round starts on its parent's core and waits for the scheduler to move it, which in a round
/// of a few milliseconds is part of the time.
fn stream_scaling(engine: &Engine, samples: &[Vec<(i64, u32)>], repeats: usize, streams: usize) -> Result<HostScaling> {
    let k_max = streams.max(1);
    // every round's rows in turn: what runs, on how many threads at once
    let plan: Vec<(Work, usize)> = (0..repeats.max(1) + 1)
        .flat_map(|_| WORKS.into_iter().flat_map(move |w| (1..=k_max).map(move |k| (w, k))))
        .collect();
    let start = std::sync::Barrier::new(k_max + 1);
    let done = std::sync::Barrier::new(k_max + 1);
    // per thread, its time in each entry of the plan it ran
    let times: Vec<Result<Vec<Option<f64>>>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..k_max)
            .map(|j| {
                let (start, done, plan) = (&start, &done, &plan);
                scope.spawn(move || -> Result<Vec<Option<f64>>> {
                    let mut st = engine.state(0);
                    let cycle = cache_cycle(CACHE_ENTRIES, j as u64);
                    let mut times = Vec::with_capacity(plan.len());
                    let mut failed = None;
                    for &(work, k) in plan {
                        // untimed, before the barrier: the work begun in warm caches
                        if j < k && failed.is_none() {
                            match work {
                                Work::Engine => {
                                    let warm = &samples[..WARM_SAMPLES.min(samples.len())];
                                    failed = run_samples(engine, &mut st, warm).err();
                                }
                                Work::Cache => {
                                    std::hint::black_box(cache_work(&cycle, (CACHE_ENTRIES / 8) as u64));
                                }
                                Work::Registers => {}
                            }
                        }
                        start.wait();
                        let t = if j < k && failed.is_none() {
                            let t0 = Instant::now();
                            let ran = match work {
                                Work::Engine => run_samples(engine, &mut st, samples),
                                Work::Registers => {
                                    std::hint::black_box(register_work(REGISTER_ITERATIONS));
                                    Ok(())
                                }
                                Work::Cache => {
                                    std::hint::black_box(cache_work(&cycle, CACHE_STEPS));
                                    Ok(())
                                }
                            };
                            match ran {
                                Ok(()) => Some(t0.elapsed().as_secs_f64()),
                                Err(e) => {
                                    failed = Some(e);
                                    None
                                }
                            }
                        } else {
                            None
                        };
                        times.push(t);
                        done.wait();
                    }
                    failed.map_or(Ok(times), Err)
                })
            })
            .collect();
        for _ in &plan {
            start.wait();
            done.wait();
        }
        handles.into_iter().map(|h| h.join().expect("a bench stream panicked")).collect()
    });
    let times = times.into_iter().collect::<Result<Vec<_>>>()?;
    // per kind of work and thread count, the median round's wall; the first round is untimed
    let walls = |kind: Work| -> Vec<f64> {
        let mut walls = vec![Vec::new(); k_max];
        for (e, &(work, k)) in plan.iter().enumerate().skip(WORKS.len() * k_max) {
            if work == kind {
                walls[k - 1].push(times[..k].iter().filter_map(|t| t[e]).fold(0f64, f64::max));
            }
        }
        walls
            .into_iter()
            .map(|mut w| {
                w.sort_by(f64::total_cmp);
                w[w.len() / 2].max(1e-12)
            })
            .collect()
    };
    let engine_walls = walls(Work::Engine);
    let rate = |k: usize| (k + 1) as f64 * samples.len() as f64 / engine_walls[k];
    let rows =
        (0..k_max).map(|k| StreamsRow { streams: k + 1, samples_per_s: rate(k), speedup: rate(k) / rate(0) }).collect();
    let loops = |kind: Work| -> Vec<ThreadsRow> {
        let w = walls(kind);
        (0..k_max)
            .map(|k| ThreadsRow { threads: k + 1, ms_per_round: w[k] * 1e3, speedup: (k + 1) as f64 * w[0] / w[k] })
            .collect()
    };
    Ok(HostScaling { streams: rows, register_loop: loops(Work::Registers), cache_loop: loops(Work::Cache) })
}

/// What [`stream_scaling`] measures: the engine's streams, and the host's own scaling beside them.
struct HostScaling {
    streams: Vec<StreamsRow>,
    register_loop: Vec<ThreadsRow>,
    cache_loop: Vec<ThreadsRow>,
}

/// The event-driven engine on the peer benchmark's network: `samples` random inputs, the median
/// of `repeats` passes over them (stepped mode) with 1 to `streams` streams at once, the first
/// row's the time per sample; and per-event latency in async mode.
pub fn engine(samples: u64, repeats: usize, streams: usize) -> Result<EngineReport> {
    let net = peers_conv(1, PEER_GAIN);
    let engine = Engine::new(&net, DT_US, Mode::Stepped)?;
    let samples: Vec<Vec<(i64, u32)>> = (0..samples.max(1)).map(|s| sample_events(1000 + s, net.n_inputs())).collect();
    let (mut events, mut synops, mut spikes, mut updates) = (0u64, 0u64, 0u64, 0u64);
    // the work, counted once (every pass does the same)
    let mut st = engine.state(0);
    for s in &samples {
        run_samples(&engine, &mut st, std::slice::from_ref(s))?;
        events += st.stats.input_events;
        synops += st.stats.synops;
        spikes += st.stats.spikes.iter().sum::<u64>();
        updates += st.stats.neuron_updates;
    }
    let n = samples.len() as f64;
    let (latency, async_rate, async_max) = async_latency(&net, &samples)?;
    // the time per sample is the one-stream row's
    let HostScaling { streams, register_loop, cache_loop } = stream_scaling(&engine, &samples, repeats, streams)?;
    let per_sample = 1.0 / streams[0].samples_per_s;
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
        async_event_latency_ns_p50: latency.quantile_ns(0.5),
        async_event_latency_ns_p99: latency.quantile_ns(0.99),
        async_event_latency_ns_max: Some(async_max as f64),
        async_input_events_per_s: async_rate,
        streams,
        register_loop,
        cache_loop,
    })
}

/// The text `braille bench` prints.
impl std::fmt::Display for TrainReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "training step of the peer conv SNN (batch {}, {} steps, forward, BPTT, Adam; {:.0} spikes per sample by layer {:?}):",
            self.batch,
            self.steps,
            self.spikes_per_sample.iter().sum::<f64>(),
            self.spikes_per_sample.iter().map(|s| s.round()).collect::<Vec<_>>()
        )?;
        for t in [&self.sparse, &self.sparse_exact, &self.dense] {
            writeln!(
                f,
                "  {:<28} {:>8.1} ms median, {:>8.1} ms best; peak RSS {:.0} MB",
                t.trainer,
                t.ms_per_train_step,
                t.ms_per_train_step_min,
                t.peak_rss_mb.unwrap_or(f64::NAN)
            )?;
        }
        writeln!(
            f,
            "  truncation at {} of the surrogate's peak: gradient cosine {:.4}, relative error {:.3}; {:.2}% of neuron-steps kept",
            self.gradient_cutoff,
            self.truncation_cosine,
            self.truncation_relative_error,
            100.0 * self.kept_fraction
        )?;
        writeln!(
            f,
            "  on {} threads; scripts/peers/compare.sh measures PyTorch, snnTorch and Norse beside these in one run, like for like",
            self.threads
        )?;
        Ok(())
    }
}

/// The text `braille bench` prints.
impl std::fmt::Display for EngineReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{:.3} ms per sample, {:.3} us per input event, {:.3} ns per synaptic event ({:.0} input events, {:.0} synops, {:.0} spikes per sample); scripts/peers/compare.sh measures the peers beside it in one run",
            self.ms_per_sample,
            self.us_per_input_event,
            self.ns_per_synop,
            self.input_events_per_sample,
            self.synops_per_sample,
            self.spikes_per_sample,
        )?;
        writeln!(
            f,
            "async mode: an input event's effects done in {:.0} ns (p50), {:.0} ns (p99), {:.0} ns at most; {:.2} M input events/s",
            self.async_event_latency_ns_p50.unwrap_or(f64::NAN),
            self.async_event_latency_ns_p99.unwrap_or(f64::NAN),
            self.async_event_latency_ns_max.unwrap_or(f64::NAN),
            self.async_input_events_per_s / 1e6
        )?;
        if self.streams.len() > 1 {
            for r in &self.streams {
                writeln!(
                    f,
                    "{} stream(s) at once, one per thread: {:.0} samples/s all together, {:.2}x one stream",
                    r.streams, r.samples_per_s, r.speedup
                )?;
            }
            let host = |rows: &[ThreadsRow]| -> String {
                rows.iter()
                    .skip(1)
                    .map(|r| format!("{} threads {:.2}x", r.threads, r.speedup))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            writeln!(
                f,
                "the host in the same rounds: arithmetic in registers {} one thread; loads from each thread's own 1 MiB {} one thread",
                host(&self.register_loop),
                host(&self.cache_loop)
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    /// The cache walk's cycle visits every entry once before it comes back.
    #[test]
    fn the_cache_cycle_is_one_cycle_through_every_entry() {
        for (n, seed) in [(1, 0), (2, 1), (7, 2), (1000, 3)] {
            let next = super::cache_cycle(n, seed);
            let (mut at, mut seen) = (0u32, vec![false; n]);
            for _ in 0..n {
                assert!(!seen[at as usize], "entry {at} of {n} visited twice");
                seen[at as usize] = true;
                at = next[at as usize];
            }
            assert_eq!(at, 0, "back at the start after {n} steps");
        }
    }
}
