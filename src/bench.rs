//! `braille bench`: the event-driven engine on the peer benchmark's network and input statistics
//! (`experiments::bench`), or a BPTT training step of that network on burn; with `--model`, any
//! model file or NIR graph on any events (`experiments::model_bench`).

use anyhow::Result;
use experiments::model_bench::{self, BenchInput, NirReading};
use experiments::tactile::SplitChoice;
use snn::engine::Mode;
use snn::nir::ImportReset;
use std::path::PathBuf;

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
    /// Time a training step instead: batch 32, forward over the 20 steps, BPTT and Adam, with the
    /// sparse trainer (truncated and exact) and with burn.
    #[arg(long)]
    train: bool,
    /// Batch size of the training step.
    #[arg(long, default_value_t = 32)]
    batch: usize,
    /// --train: the sparse trainer's truncation (surrogate derivatives below this fraction of
    /// their peak count as zero), beside its exact run.
    #[arg(long, default_value_t = learn::sparse::DEFAULT_CUTOFF, requires = "train")]
    gradient_cutoff: f32,
    /// Any network instead of the peer benchmark's: a model file, or a NIR graph (HDF5, from
    /// snnTorch, Norse or `braille export`).
    #[arg(long, conflicts_with = "train")]
    model: Option<PathBuf>,
    /// --model: an event file (AEDAT 4.0, CSV, NumPy) read as one stream [default: random input
    /// with the peer benchmark's statistics, --samples of them].
    #[arg(long, requires = "model", conflicts_with = "data")]
    events: Option<PathBuf>,
    /// --events: multiply every timestamp by this (a graph written for another step, such as
    /// snnTorch's 100 us graphs of 5 ms bins: 0.02).
    #[arg(long, default_value_t = 1.0, requires = "events")]
    time_scale: f64,
    /// --model: a tactile dataset folder whose samples are fed, encoded as the model was trained.
    #[arg(long, requires = "model")]
    data: Option<PathBuf>,
    /// --data: which split.
    #[arg(long, value_enum, default_value = "test")]
    split: BenchSplit,
    /// --data with a NIR graph: take the data's encoding from this model file.
    #[arg(long, requires = "data")]
    like: Option<PathBuf>,
    /// --model: the engine's mode.
    #[arg(long, value_enum, default_value = "stepped")]
    mode: Mode,
    /// --model: run 1 to N independent streams at once, one per thread, and report the scaling.
    #[arg(long, default_value_t = 1)]
    streams: usize,
    /// A NIR graph's step, in microseconds (snnTorch's exporter assumes 100 us).
    #[arg(long, default_value_t = 100)]
    dt_us: i64,
    /// How a NIR graph's neurons reset (NIR's own: to v_reset).
    #[arg(long, value_enum, default_value = "to-v-reset")]
    reset: ImportReset,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchSplit {
    Train,
    Test,
    All,
}

fn model(args: &Args, path: &std::path::Path) -> Result<()> {
    let net = model_bench::load_network(path, NirReading { dt_us: args.dt_us, reset: args.reset })?;
    let input = match (&args.events, &args.data) {
        (Some(e), _) => BenchInput::Events { path: e.clone(), time_scale: args.time_scale },
        (None, Some(d)) => BenchInput::Data {
            dir: d.clone(),
            split: match args.split {
                BenchSplit::Train => SplitChoice::Train,
                BenchSplit::Test => SplitChoice::Test,
                BenchSplit::All => SplitChoice::All,
            },
            like: args.like.clone(),
        },
        (None, None) => BenchInput::Random { samples: args.samples },
    };
    let r = model_bench::run(&net, &path.display().to_string(), &input, args.mode, args.streams)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    println!(
        "{} ({:?}, dt {} us, {:?} mode) on {}: {:.1} input events, {:.0} synops, {:.1} spikes per sample{}",
        r.model,
        r.source,
        r.dt_us,
        r.mode,
        r.input,
        r.input_events_per_sample,
        r.synops_per_sample,
        r.spikes_per_sample,
        r.accuracy.map_or(String::new(), |a| format!("; accuracy {:.2}%", 100.0 * a))
    );
    let l = &r.latency;
    println!(
        "one stream: per event {:.0} ns (p50), {:.0} ns (p99), {:.0} ns (p99.9), {:.0} ns at most, clock {:.0} ns included; {:.2} M input events/s",
        l.p50_ns,
        l.p99_ns,
        l.p999_ns,
        l.max_ns,
        r.clock_overhead_ns,
        r.input_events_per_s / 1e6
    );
    println!("| streams | M input events/s | speedup | efficiency | p50 ns | p99 ns | p99.9 ns | max ns |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    for s in &r.scaling {
        println!(
            "| {} | {:.2} | {:.2}x | {:.0}% | {:.0} | {:.0} | {:.0} | {:.0} |",
            s.streams,
            s.input_events_per_s / 1e6,
            s.speedup,
            100.0 * s.efficiency,
            s.latency.p50_ns,
            s.latency.p99_ns,
            s.latency.p999_ns,
            s.latency.max_ns
        );
    }
    if r.scaling.len() > r.cores {
        println!("({} streams on {} cores: beyond that the streams share cores)", r.scaling.len(), r.cores);
    }
    for e in &r.energy {
        println!(
            "energy estimate, {}: {:.1} nJ per sample ({} pJ per synop)",
            e.platform, e.nj_per_sample, e.pj_per_synop
        );
    }
    Ok(())
}

pub fn run(args: Args) -> Result<()> {
    if let Some(path) = args.model.clone() {
        return model(&args, &path);
    }
    if args.train {
        let r = experiments::bench::train_step(args.batch, args.repeats, args.gradient_cutoff)?;
        if args.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            println!(
                "training step of the peer conv SNN (batch {}, {} steps, forward, BPTT, Adam; {:.0} spikes per sample by layer {:?}):",
                r.batch,
                r.steps,
                r.spikes_per_sample.iter().sum::<f64>(),
                r.spikes_per_sample.iter().map(|s| s.round()).collect::<Vec<_>>()
            );
            for t in [&r.sparse, &r.sparse_exact, &r.dense] {
                println!(
                    "  {:<28} {:>8.1} ms median, {:>8.1} ms best; peak RSS {:.0} MB",
                    t.trainer,
                    t.ms_per_train_step,
                    t.ms_per_train_step_min,
                    t.peak_rss_mb.unwrap_or(f64::NAN)
                );
            }
            println!(
                "  truncation at {} of the surrogate's peak: gradient cosine {:.4}, relative error {:.3}; {:.2}% of neuron-steps kept",
                r.gradient_cutoff,
                r.truncation_cosine,
                r.truncation_relative_error,
                100.0 * r.kept_fraction
            );
            println!(
                "  peers (the shared benchmark's figures): PyTorch 59.6, snnTorch 97.1, Norse 78.1 ms; scripts/peers/compare.sh measures them beside ours"
            );
        }
        return Ok(());
    }
    let r = experiments::bench::engine(args.samples, args.repeats)?;
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
