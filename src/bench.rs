//! `braille bench`: the event-driven engine on the peer benchmark's network and input statistics
//! (`experiments::bench`), or a BPTT training step of that network on burn.

use anyhow::Result;

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

pub fn run(args: Args) -> Result<()> {
    if args.train {
        let r = experiments::bench::train_step(args.batch, args.repeats)?;
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
