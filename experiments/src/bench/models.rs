//! Any model on any events (`braille bench --model`): a model file or a NIR graph (from snnTorch,
//! Norse or this project), fed an event file, a tactile dataset's split, or the peer benchmark's
//! random input, on the event-driven engine in stepped or async mode; per-event latency, input
//! events per second, SynOps, spikes and energy estimates per sample, and the scaling from one
//! stream on one core to N independent streams on N cores. A loaded network is shared by every
//! stream; each stream owns its engine state.

use crate::error::{Error, Result};
use encoders::formats::{self, OpenOptions};
use hdrhistogram::Histogram;
use learn::data::TactileEncoding;
use pipeline::network::{InputMap, LoadedNetwork};
pub use pipeline::network::{
    ModelSource, NirReading, PEER_INPUT, RunRecord, load_network, peer_network, peer_sample_events, record_events,
    run_events,
};
use serde::Serialize;
use snn::energy::SYNOP_ENERGIES;
use snn::engine::{Engine, EngineState, Mode};
use snn::model_file::Readout;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What the network is fed.
#[derive(Debug, Clone)]
pub enum BenchInput {
    /// One stream: an event file, read chunk by chunk (memory bounded by the decoder's chunk),
    /// every timestamp multiplied by `time_scale` (a graph written for another step: snnTorch's
    /// 100 us graphs of 5 ms bins take 0.02).
    Events { path: PathBuf, time_scale: f64 },
    /// The samples of a tactile dataset folder's split, encoded as the model was trained (a NIR
    /// graph: the encoding fitted to the data at the graph's step, or `like`'s).
    Data { dir: PathBuf, split: crate::eval::tactile::SplitChoice, like: Option<PathBuf> },
    /// The peer benchmark's statistics: `samples` random inputs, 20 steps, 0.75% of inputs per
    /// step.
    Random { samples: u64 },
}

/// One sample: input events `(t_us, input)` in time order, when it ends, and its label.
pub(crate) struct Sample {
    pub(crate) events: Vec<(i64, u32)>,
    pub(crate) end_us: i64,
    pub(crate) label: Option<usize>,
}

/// The input as the streams read it.
pub(crate) enum Feed {
    Samples(Vec<Sample>),
    File { path: PathBuf, map: InputMap, time_scale: f64 },
}

/// Chunks of the file's events mapped to inputs, handed to `visit` one chunk at a time.
pub(crate) fn for_each_file_chunk(
    path: &Path,
    map: &InputMap,
    time_scale: f64,
    mut visit: impl FnMut(&[(i64, u32)]) -> Result<()>,
) -> Result<i64> {
    let mut src = formats::open(path, &OpenOptions::default())?;
    let mut buf: Vec<(i64, u32)> = Vec::with_capacity(formats::CHUNK_EVENTS);
    let (mut k, mut last) = (0u64, 0i64);
    while let Some(chunk) = src.next_chunk()? {
        buf.clear();
        for e in chunk {
            let t = if time_scale == 1.0 { e.t_us } else { (e.t_us as f64 * time_scale).round() as i64 };
            buf.push((t, map.index(e, k, path)?));
            k += 1;
        }
        last = buf.last().map_or(last, |&(t, _)| t);
        visit(&buf)?;
    }
    Ok(last + 1)
}

/// Percentiles of a latency distribution, in nanoseconds.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Latency {
    pub events: u64,
    pub p50_ns: f64,
    pub p99_ns: f64,
    pub p999_ns: f64,
    pub max_ns: f64,
    pub mean_ns: f64,
}

pub(crate) fn latency_of(h: &Histogram<u64>) -> Latency {
    let q = |q: f64| h.value_at_quantile(q) as f64;
    Latency {
        events: h.len(),
        p50_ns: q(0.5),
        p99_ns: q(0.99),
        p999_ns: q(0.999),
        max_ns: h.max() as f64,
        mean_ns: h.mean(),
    }
}

pub(crate) fn new_histogram() -> Histogram<u64> {
    Histogram::new_with_bounds(1, 60_000_000_000, 3).expect("valid bounds")
}

/// One stream's pass over the whole input.
struct Pass {
    latency: Histogram<u64>,
    events: u64,
    synops: u64,
    spikes: Vec<u64>,
    readouts: Vec<(Vec<f32>, Option<usize>)>,
}

/// Runs every sample of `feed` through a stream. `per_event`: time each push (the latency
/// distribution); otherwise no clock is read (the caller times the whole pass).
fn pass(engine: &Engine, st: &mut EngineState, feed: &Feed, readout: Readout, per_event: bool) -> Result<Pass> {
    let n_out = engine.n_outputs();
    let mut out = Pass { latency: new_histogram(), events: 0, synops: 0, spikes: Vec::new(), readouts: Vec::new() };
    let run = |events: &[(i64, u32)], st: &mut EngineState, out: &mut Pass| -> Result<()> {
        if per_event {
            for &(t, i) in events {
                let t0 = Instant::now();
                engine.push(st, t, i, 1.0)?;
                out.latency.saturating_record((t0.elapsed().as_nanos() as u64).max(1));
            }
        } else {
            for &(t, i) in events {
                engine.push(st, t, i, 1.0)?;
            }
        }
        out.events += events.len() as u64;
        Ok(())
    };
    let close = |st: &mut EngineState, end_us: i64, label: Option<usize>, out: &mut Pass| {
        engine.finish(st, end_us);
        out.synops += st.stats.synops;
        if out.spikes.len() < st.stats.spikes.len() {
            out.spikes.resize(st.stats.spikes.len(), 0);
        }
        for (a, b) in out.spikes.iter_mut().zip(&st.stats.spikes) {
            *a += b;
        }
        let r = match readout {
            Readout::MaxMembrane => st.output_v_max().to_vec(),
            Readout::SpikeCount => st.output_counts(n_out).into_iter().map(|c| c as f32).collect(),
        };
        out.readouts.push((r, label));
    };
    let wrap = |source: snn::Error, what: String| Error::Engine { what, source, hint: "" };
    match feed {
        Feed::Samples(samples) => {
            for (k, s) in samples.iter().enumerate() {
                engine.reset(st, 0);
                run(&s.events, st, &mut out).map_err(|e| match e {
                    Error::Snn(e) => wrap(e, format!("sample {k}")),
                    other => other,
                })?;
                close(st, s.end_us, s.label, &mut out);
            }
        }
        Feed::File { path, map, time_scale } => {
            // the stream starts at its first event (a recording's clock may start anywhere)
            let mut started = false;
            let end = for_each_file_chunk(path, map, *time_scale, |chunk| {
                if !started {
                    engine.reset(st, chunk.first().map_or(0, |e| e.0));
                    started = true;
                }
                run(chunk, st, &mut out).map_err(|e| match e {
                    Error::Snn(e) => wrap(e, path.display().to_string()),
                    other => other,
                })
            })?;
            if !started {
                engine.reset(st, 0);
            }
            close(st, end, None, &mut out);
        }
    }
    Ok(out)
}

/// The share of readouts whose highest output is the label, when every readout has one.
pub(crate) fn accuracy_of(readouts: &[(Vec<f32>, Option<usize>)]) -> Option<f64> {
    let labelled: Vec<(usize, usize)> =
        readouts.iter().filter_map(|(r, l)| l.map(|l| (crate::eval::scoring::argmax(r.iter().copied()), l))).collect();
    (!labelled.is_empty() && labelled.len() == readouts.len())
        .then(|| labelled.iter().filter(|(p, l)| p == l).count() as f64 / labelled.len() as f64)
}

/// The engine's work and speed with `streams` streams at once, one per thread.
#[derive(Debug, Clone, Serialize)]
pub struct StreamsRow {
    pub streams: usize,
    /// Input events handled per second, all streams together (untimed pass).
    pub input_events_per_s: f64,
    /// Against one stream.
    pub speedup: f64,
    /// `speedup / streams`.
    pub efficiency: f64,
    /// Per event, all streams' events together (timed pass).
    pub latency: Latency,
}

/// An energy estimate per sample.
#[derive(Debug, Clone, Serialize)]
pub struct EnergyRow {
    pub platform: &'static str,
    pub pj_per_synop: f64,
    pub nj_per_sample: f64,
    pub source: &'static str,
}

/// What `braille bench --model` measures.
#[derive(Debug, Clone, Serialize)]
pub struct ModelBench {
    pub model: String,
    pub source: ModelSource,
    pub dt_us: i64,
    pub mode: Mode,
    pub input: String,
    pub samples: usize,
    pub input_events_per_sample: f64,
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    /// Per layer with neurons (in layer order; layers without neurons count 0).
    pub spikes_per_layer_per_sample: Vec<f64>,
    /// When the input has labels and the network one output per class.
    pub accuracy: Option<f64>,
    /// One stream, every push timed (the first row of `scaling`): in stepped mode a push that opens a new step carries the
    /// whole previous step's work; in async mode each push completes all the event's effects.
    pub latency: Latency,
    /// What a timed push costs with nothing to do (two clock reads), included in `latency`.
    pub clock_overhead_ns: f64,
    /// One stream, untimed pass (the first row of `scaling`).
    pub input_events_per_s: f64,
    pub scaling: Vec<StreamsRow>,
    pub cores: usize,
    pub energy: Vec<EnergyRow>,
}

/// The clock's own cost: the median of back-to-back reads.
fn clock_overhead_ns() -> f64 {
    let mut v: Vec<u64> = (0..2001)
        .map(|_| {
            let t0 = Instant::now();
            t0.elapsed().as_nanos() as u64
        })
        .collect();
    v.sort_unstable();
    v[v.len() / 2] as f64
}

/// Reads the input into what the streams replay (an event file stays on disk).
pub(crate) fn feed(net: &LoadedNetwork, input: &BenchInput) -> Result<(Feed, String)> {
    Ok(match input {
        BenchInput::Events { path, time_scale } => {
            if !(time_scale.is_finite() && *time_scale > 0.0) {
                return Err(Error::Setting {
                    name: "time scale",
                    value: time_scale.to_string(),
                    expected: "a positive factor",
                });
            }
            let src = formats::open(path, &OpenOptions::default())?;
            let map = InputMap::new(&net.network, src.info().resolution, path)?;
            let scaled = if *time_scale == 1.0 { String::new() } else { format!(", times x {time_scale}") };
            (
                Feed::File { path: path.clone(), map, time_scale: *time_scale },
                format!("{} (one stream{scaled})", path.display()),
            )
        }
        BenchInput::Random { samples } => {
            // the peer benchmark's 20 steps of 1 ms, one per step of this network
            let n = net.network.n_inputs();
            let per_step = |t: i64| {
                t / crate::bench::engine::DT_US * net.dt_us
                    + t % crate::bench::engine::DT_US * net.dt_us / crate::bench::engine::DT_US
            };
            let samples: Vec<Sample> = (0..(*samples).max(1))
                .map(|s| Sample {
                    events: crate::bench::engine::sample_events(1000 + s, n)
                        .into_iter()
                        .map(|(t, i)| (per_step(t), i))
                        .collect(),
                    end_us: crate::bench::engine::STEPS as i64 * net.dt_us,
                    label: None,
                })
                .collect();
            let k = samples.len();
            (
                Feed::Samples(samples),
                format!("{k} random samples (the peer benchmark's statistics: 20 steps, 0.75% of inputs per step)"),
            )
        }
        BenchInput::Data { dir, split, like } => {
            let data = encoders::dataset::Dataset::load(
                dir,
                net.encoding.as_ref().map_or(crate::train::recipe::SnnRecipe::default().period_us, |e| e.period_us),
            )?;
            let encoding = match (like, &net.encoding) {
                (Some(p), _) => crate::eval::tactile::encoding_of(&pipeline::models::load_snn(p)?, p)?,
                (None, Some(e)) => e.clone(),
                (None, None) => TactileEncoding::fit(&data, Default::default(), net.dt_us)?,
            };
            if encoding.dt_us != net.dt_us {
                return Err(Error::Data {
                    path: dir.clone(),
                    what: format!("the encoding steps {} us, the network {} us", encoding.dt_us, net.dt_us),
                });
            }
            if encoding.n_inputs() != net.network.n_inputs() {
                return Err(Error::Data {
                    path: dir.clone(),
                    what: format!(
                        "the data gives {} inputs ({} channels{}), the network takes {}",
                        encoding.n_inputs(),
                        encoding.channels,
                        if encoding.merge_polarities { ", polarities merged" } else { ", OFF and ON" },
                        net.network.n_inputs()
                    ),
                });
            }
            let data = encoding.select(&data)?;
            let encoder = encoding.encoder(data.resolution())?;
            let wanted = match split {
                crate::eval::tactile::SplitChoice::Test => Some(encoders::dataset::Split::Test),
                crate::eval::tactile::SplitChoice::Train => Some(encoders::dataset::Split::Train),
                crate::eval::tactile::SplitChoice::All => None,
                crate::eval::tactile::SplitChoice::Validation { .. } => {
                    return Err(Error::Setting {
                        name: "split",
                        value: split.name().into(),
                        expected: "train, test or all",
                    });
                }
            };
            let end_us = encoding.dt_us * encoding.steps as i64;
            let samples = data
                .samples
                .iter()
                .filter(|s| wanted.is_none_or(|w| s.split == w))
                .map(|s| Ok(Sample { events: encoding.events_of(&data, s, &encoder)?, end_us, label: Some(s.label) }))
                .collect::<Result<Vec<_>>>()?;
            let k = samples.len();
            (Feed::Samples(samples), format!("{} ({} split, {k} samples)", dir.display(), split.name()))
        }
    })
}

/// Benchmarks `net` on `input` in `mode`: 1 to `streams` streams at once on as many threads, each
/// timed per event and then untimed; the one-stream row gives the latency and rate.
pub fn run(net: &LoadedNetwork, model: &str, input: &BenchInput, mode: Mode, streams: usize) -> Result<ModelBench> {
    let engine = Engine::new(&net.network, net.dt_us, mode).map_err(|e| Error::Engine {
        what: model.to_string(),
        source: e,
        hint: if mode == Mode::Async {
            " (async mode runs LIF and IF layers without bias or recurrence; use --mode stepped)"
        } else {
            ""
        },
    })?;
    let (feed, what) = feed(net, input)?;
    let mut st = engine.state(0);
    // warm up, and the work and readouts (identical in every pass)
    let warm = pass(&engine, &mut st, &feed, net.readout, false)?;
    let n = warm.readouts.len().max(1) as f64;
    let accuracy = accuracy_of(&warm.readouts);
    let synops_per_sample = warm.synops as f64 / n;
    let mut scaling = Vec::new();
    for k in 1..=streams.max(1) {
        let results: Vec<Result<(Pass, Pass, f64)>> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..k)
                .map(|_| {
                    s.spawn(|| -> Result<(Pass, Pass, f64)> {
                        let mut st = engine.state(0);
                        let timed = pass(&engine, &mut st, &feed, net.readout, true)?;
                        let t0 = Instant::now();
                        let untimed = pass(&engine, &mut st, &feed, net.readout, false)?;
                        Ok((timed, untimed, t0.elapsed().as_secs_f64()))
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().expect("a bench stream panicked")).collect()
        });
        let mut latency = new_histogram();
        let (mut events, mut wall) = (0u64, 0f64);
        for r in results {
            let (timed, untimed, secs) = r?;
            latency.add(&timed.latency).expect("same bounds");
            events += untimed.events;
            wall = wall.max(secs);
        }
        let rate = events as f64 / wall.max(1e-12);
        let base: f64 = scaling.first().map_or(rate, |r: &StreamsRow| r.input_events_per_s);
        scaling.push(StreamsRow {
            streams: k,
            input_events_per_s: rate,
            speedup: rate / base,
            efficiency: rate / base / k as f64,
            latency: latency_of(&latency),
        });
    }
    Ok(ModelBench {
        model: model.to_string(),
        source: net.source,
        dt_us: net.dt_us,
        mode,
        input: what,
        samples: warm.readouts.len(),
        input_events_per_sample: warm.events as f64 / n,
        synops_per_sample,
        spikes_per_sample: warm.spikes.iter().sum::<u64>() as f64 / n,
        spikes_per_layer_per_sample: warm.spikes.iter().map(|&s| s as f64 / n).collect(),
        accuracy,
        latency: scaling[0].latency,
        clock_overhead_ns: clock_overhead_ns(),
        input_events_per_s: scaling[0].input_events_per_s,
        scaling,
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        energy: SYNOP_ENERGIES
            .iter()
            .map(|e| EnergyRow {
                platform: e.platform,
                pj_per_synop: e.pj_per_op,
                nj_per_sample: e.nanojoules(synops_per_sample),
                source: e.source,
            })
            .collect(),
    })
}

/// The text `braille bench` prints.
impl std::fmt::Display for ModelBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} ({:?}, dt {} us, {:?} mode) on {}: {:.1} input events, {:.0} synops, {:.1} spikes per sample{}",
            self.model,
            self.source,
            self.dt_us,
            self.mode,
            self.input,
            self.input_events_per_sample,
            self.synops_per_sample,
            self.spikes_per_sample,
            self.accuracy.map_or(String::new(), |a| format!("; accuracy {:.2}%", 100.0 * a))
        )?;
        let l = &self.latency;
        writeln!(
            f,
            "one stream: per event {:.0} ns (p50), {:.0} ns (p99), {:.0} ns (p99.9), {:.0} ns at most, clock {:.0} ns included; {:.2} M input events/s",
            l.p50_ns,
            l.p99_ns,
            l.p999_ns,
            l.max_ns,
            self.clock_overhead_ns,
            self.input_events_per_s / 1e6
        )?;
        writeln!(f, "| streams | M input events/s | speedup | efficiency | p50 ns | p99 ns | p99.9 ns | max ns |")?;
        writeln!(f, "| --- | --- | --- | --- | --- | --- | --- | --- |")?;
        for s in &self.scaling {
            writeln!(
                f,
                "| {} | {:.2} | {:.2}x | {:.0}% | {:.0} | {:.0} | {:.0} | {:.0} |",
                s.streams,
                s.input_events_per_s / 1e6,
                s.speedup,
                100.0 * s.efficiency,
                s.latency.p50_ns,
                s.latency.p99_ns,
                s.latency.p999_ns,
                s.latency.max_ns
            )?;
        }
        if self.scaling.len() > self.cores {
            writeln!(
                f,
                "({} streams on {} cores: beyond that the streams share cores)",
                self.scaling.len(),
                self.cores
            )?;
        }
        for e in &self.energy {
            writeln!(
                f,
                "energy estimate, {}: {:.1} nJ per sample ({} pJ per synop)",
                e.platform, e.nj_per_sample, e.pj_per_synop
            )?;
        }
        Ok(())
    }
}
