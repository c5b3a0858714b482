//! `braille run`: a model file or NIR graph on an event file, every spike of every layer written
//! as CSV (`layer,step,neuron`), for comparing this engine with another simulator spike for spike.

use anyhow::Result;
use experiments::bench::models::{self as model_bench, NirReading};
use snn::nir::ImportReset;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A model file or a NIR graph.
    #[arg(long)]
    model: PathBuf,
    /// Input events (AEDAT 4.0, CSV, NumPy), mapped onto the network's input as `braille bench`
    /// maps them, from time 0.
    #[arg(long)]
    events: PathBuf,
    /// Steps to run [default: up to the last event].
    #[arg(long)]
    steps: Option<usize>,
    /// A NIR graph's step, in microseconds.
    #[arg(long, default_value_t = 100)]
    dt_us: i64,
    /// How a NIR graph's neurons reset.
    #[arg(long, value_enum, default_value = "to-v-reset")]
    reset: ImportReset,
    /// Where to write the spikes (CSV: layer,step,neuron; `layer` counts the layers with neurons).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let net = model_bench::load_network(&args.model, NirReading { dt_us: args.dt_us, reset: args.reset })?;
    let r = model_bench::run_events(&net, &args.events, args.steps)?;
    r.write_spikes_csv(&args.out)?;
    eprintln!(
        "{} steps of {} us; spikes per layer {:?} (layers {:?}); the engine's output agrees with the time-stepped reference; wrote {}",
        r.steps,
        net.dt_us,
        r.spikes_per_layer,
        r.layers,
        args.out.display()
    );
    Ok(())
}
