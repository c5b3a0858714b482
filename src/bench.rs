//! `braille bench`: the event-driven engine on the peer benchmark's network and input statistics
//! (`experiments::bench::engine`), or a BPTT training step of that network on burn; with `--model`, any
//! model file or NIR graph on any events (`experiments::bench::models`).

use crate::common::emit;
use anyhow::{Result, bail};
use experiments::bench::models::{self as model_bench, BenchInput, NirReading};
use experiments::eval::tactile::SplitChoice;
use snn::engine::Mode;
use snn::model_file::Arch;
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
    /// Run 1 to N independent streams at once, one per thread, and report the scaling (the peer
    /// benchmark's network, or --model's).
    #[arg(long, default_value_t = 1)]
    streams: usize,
    /// A NIR graph's step, in microseconds (snnTorch's exporter assumes 100 us).
    #[arg(long, default_value_t = 100)]
    dt_us: i64,
    /// How a NIR graph's neurons reset (NIR's own: to v_reset).
    #[arg(long, value_enum, default_value = "to-v-reset")]
    reset: ImportReset,
    /// --model: run it in a chip's arithmetic (docs/chips.md), every step timed, beside the float
    /// engine on the same input in the same run (time per sample of both, and their ratio).
    #[arg(long, requires = "model")]
    chip: Option<snn::chip::Chip>,
    /// --chip: how float weights become the chip's integers (Rockpool's quantisers).
    #[arg(long, value_enum, default_value = "global", requires = "chip")]
    quantisation: snn::chip::xylo::Quantisation,
    /// --chip: every neuron every step, or only neurons with a state or an input.
    #[arg(long, value_enum, default_value = "event-driven", requires = "chip")]
    chip_run: snn::chip::xylo::Run,
    /// Time the words of a live sensor instead: SIMULATED rows of the EV board (`nominal`, a test
    /// sensor build) served over TCP at the recorded pace, read by each architecture's shipped
    /// reader; the latency from a word's last detection arriving to the word printed (p50, p99).
    #[arg(long, conflicts_with_all = ["train", "model"])]
    live: bool,
    /// --live: rows served, one after another.
    #[arg(long, default_value_t = 6, requires = "live")]
    live_rows: usize,
    /// --live: the sliding speed, mm/s.
    #[arg(long, default_value_t = 16.0, requires = "live")]
    live_speed: f64,
    /// --live: the indentation depth, mm.
    #[arg(long, default_value_t = 1.0, requires = "live")]
    live_depth: f64,
    /// --model with a ResNet: threads of the batch --batch measurement (the first is batch 1 on
    /// one thread) [default: every core].
    #[arg(long, requires = "model")]
    threads: Option<usize>,
    /// --model with a ResNet: cut the windows from one trial of this board's rows (SIMULATED,
    /// `nominal`, a test sensor build, 8 mm/s, 1.5 mm) instead of --samples random ones.
    #[arg(long, requires = "model", value_parser = corpus::boards::parse_board)]
    board: Option<sim::BoardKind>,
    /// --model with a ResNet, random windows: the share of non-zero cells.
    #[arg(long, default_value_t = 0.02, requires = "model")]
    density: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchSplit {
    Train,
    Test,
    All,
}

pub fn run(args: Args) -> Result<()> {
    if let Some(path) = args.model.clone() {
        return model(&args, &path);
    }
    if args.live {
        let spec = experiments::bench::live::LiveSpec::ev_nominal(args.live_rows, args.live_speed, args.live_depth);
        let models = crate::common::repo_path("models/nominal");
        let r = experiments::bench::live::live(&spec, &models, &[Arch::Snn, Arch::Resnet])?;
        return emit(&r, args.json);
    }
    if args.train {
        return emit(
            &experiments::bench::engine::train_step(args.batch, args.repeats, args.gradient_cutoff)?,
            args.json,
        );
    }
    emit(&experiments::bench::engine::engine(args.samples, args.repeats, args.streams)?, args.json)
}

fn model(args: &Args, path: &std::path::Path) -> Result<()> {
    // a ResNet model file is timed on windows; anything else (an SNN file, a NIR graph) on events,
    // whose loader names what is wrong with the file
    if let Ok(pipeline::models::Model::Resnet(m)) = pipeline::models::load(path) {
        return resnet(args, path, &m);
    }
    let net = model_bench::load_network(path, NirReading { dt_us: args.dt_us, reset: args.reset })?;
    let split = match args.split {
        BenchSplit::Train => SplitChoice::Train,
        BenchSplit::Test => SplitChoice::Test,
        BenchSplit::All => SplitChoice::All,
    };
    let input = match (&args.events, &args.data) {
        (Some(e), _) => BenchInput::Events { path: e.clone(), time_scale: args.time_scale },
        (None, Some(d)) => BenchInput::Data { dir: d.clone(), split, like: args.like.clone() },
        (None, None) => BenchInput::Random { samples: args.samples },
    };
    let name = path.display().to_string();
    let Some(chip) = args.chip else {
        return emit(&model_bench::run(&net, &name, &input, args.mode, args.streams)?, args.json);
    };
    if args.mode != Mode::Stepped || args.streams != 1 {
        bail!("--chip runs one stream beside the float engine in stepped mode (no --mode async, no --streams)");
    }
    let choice = experiments::eval::chip::ChipChoice { chip, quantisation: args.quantisation, run: args.chip_run };
    emit(&experiments::bench::chip::run(&net, &name, &input, choice)?, args.json)
}

/// `--model` with a ResNet model file: our folded path and burn's on the same windows.
fn resnet(args: &Args, path: &std::path::Path, m: &pipeline::models::ResnetModel) -> Result<()> {
    use experiments::bench::resnet::{ResnetBenchSpec, Windows};
    if args.events.is_some() || args.data.is_some() || args.chip.is_some() || args.streams != 1 {
        bail!("a ResNet is timed on windows (random, or --board's): no --events, --data, --chip or --streams");
    }
    if !(0.0..=1.0).contains(&args.density) {
        bail!("--density {}: a share of cells, 0 to 1", args.density);
    }
    let windows = match &args.board {
        Some(board) => Windows::Board { board: board.clone(), realism: sim::Realism::Nominal },
        None => Windows::Random { count: args.samples as usize, density: args.density, seed: 1 },
    };
    let threads = args.threads.unwrap_or_else(rayon::current_num_threads);
    let spec = ResnetBenchSpec { windows, batch: args.batch, threads, repeats: args.repeats };
    let r = experiments::bench::resnet::run(m, &path.display().to_string(), &spec, &crate::common::Bar::default())?;
    emit(&r, args.json)
}
