//! `braille`: read Braille from event-based touch. The binary parses arguments, calls the
//! libraries (`pipeline` to read, `corpus` for data, `experiments` to train, evaluate and
//! benchmark), prints what they return and draws it; `demo` shows what works on built-in defaults.

mod baselines;
mod bench;
mod calibrate_reader;
mod chars_report;
mod chip_report;
mod common;
mod convert;
mod demo;
mod ensemble;
mod eval;
mod icub_report;
mod info;
mod label_check;
mod letters_report;
mod nir_cli;
mod plot;
mod read;
mod recordings;
mod replay;
mod report;
mod robustness;
mod run;
mod set_band;
mod sim_check;
mod sim_dataset;
mod sim_jobs;
mod simulate;
mod tactile_report;
mod train;
mod translate;
mod words_report;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "braille",
    version,
    about = "Neuromorphic Braille reading: event streams from a tactile event camera (Evetac) in, characters and words out",
    long_about = "Neuromorphic Braille reading.\n\nEvent files are AEDAT 4.0 (iniVation DV, LZ4/ZSTD), CSV (t_us,x,y,p) or NumPy .npy (Tonic's fields x, y, t, p); the format is chosen by magic bytes, then by extension."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Read the words in an event stream (a file, standard input or a live sensor's network stream,
    /// as it arrives): segmentation network, character classifier (ResNet or SNN), temporal
    /// filter, spelling.
    Read(read::Args),
    /// Simulate scans of Braille boards with the virtual Evetac: event files and ground truth.
    Simulate(simulate::Args),
    /// Train a model and save it: an SNN on a tactile dataset folder (a named recipe, the recipe
    /// derived from the data, or `--search`), or either architecture on simulated windows.
    Train(Box<train::Args>),
    /// A trained model's accuracy: on a dataset folder's split (the SNN, on the event-driven
    /// engine), `eval chars` on simulated windows of a board, `eval words` a reader on simulated
    /// scans of a board.
    Eval(eval::Args),
    /// Time the event-driven engine: on the peer benchmark's network, or any model file or NIR
    /// graph (`--model`) on an event file, a dataset split or random input; `--train` times the
    /// trainers' step.
    Bench(bench::Args),
    /// Export a trained SNN to NIR (HDF5), the format neuromorphic chips' toolchains read.
    Export(nir_cli::ExportArgs),
    /// Import a NIR graph into a model file the engine runs.
    Import(nir_cli::ImportArgs),
    /// Print to Braille cells and back: the paper's letters, or Unified English Braille grade 1
    /// or 2 (contracted) by liblouis's tables; `--spec` checks a code against liblouis's own tests.
    Translate(translate::Args),
    /// Regenerate every results table and figure into one folder with an index (Markdown, JSON,
    /// PNG; `--quick` for a fast check that it all runs), or one report: `report chars`, `words`,
    /// `letters`, `icub`, `tactile`, `chip`.
    Report(report::Args),
    /// Run the built-in demonstration: both readers on SIMULATED scans of the EV board (a sensor
    /// build no model saw) and of a contracted UEB sentence, then real iCub recordings spelled
    /// into a stream, written to AEDAT4, read back and classified by the shipped SNN on the
    /// event-driven engine.
    Demo(experiments::demo::DemoSpec),
    /// The simulator's checks and other products: `sim check` (physics), `sim labels` (the
    /// labeling pipeline against the truth), `sim robustness` (the classifiers against each
    /// nuisance), `sim dataset` (a tactile dataset of another layout).
    Sim(sim_jobs::Args),
    /// Serve an event file as a live sensor: DV's AEDAT 4.0 network stream at the recorded pace,
    /// for `read tcp://HOST:PORT`, dv-processing or DV.
    Replay(replay::Args),
    /// A lab's own recorded scans (a folder of event files and a manifest): `recordings check`.
    Recordings(recordings::Args),
    /// Summarise an event file: events, duration, rate, ON/OFF ratio, resolution, time range.
    Info(info::Args),
    /// Convert an event file between AEDAT4, CSV and NumPy (.npy), streaming with bounded memory.
    Convert(convert::Args),
    /// Plot an event file as a heat map and an event raster (PNG).
    Plot(plot::Args),
    /// The non-spiking floors of a tactile dataset folder (ridge and logistic regression on
    /// binned event counts), chosen on the SNN search's validation hold-out.
    Baselines(baselines::Args),
    /// Choose a segmentation network's operating point (threshold, shortest segment) on the
    /// SIMULATED validation words, never a test board; `--write` records it in the model file.
    CalibrateReader(calibrate_reader::Args),
    /// Centre a character classifier's windows in a band of rows wider than its crop from now on,
    /// its weights unchanged (a row the board's yaw moves past the crop is centred back whole).
    SetBand(set_band::Args),
    /// Run a model file or NIR graph on an event file and write every spike of every layer (CSV),
    /// to compare with another simulator spike for spike.
    Run(run::Args),
    /// Merge trained SNNs of one architecture into one network: the members side by side, their
    /// readouts summed at every step.
    Ensemble(ensemble::Args),
}

fn main() -> ExitCode {
    // the default action of SIGPIPE (Rust ignores it, so `println!` to a closed pipe panics)
    #[cfg(unix)]
    // SAFETY: at the start of main, before any thread is spawned; SIG_DFL is a valid handler.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse_from(train::flags_as_keys(old_names(std::env::args_os().collect())));
    let result = match cli.command {
        Command::Info(a) => info::run(a),
        Command::Convert(a) => convert::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Train(a) => train::run(*a),
        Command::Eval(a) => eval::run(a),
        Command::Baselines(a) => baselines::run(a),
        Command::Run(a) => run::run(a),
        Command::Read(a) => read::run(a),
        Command::Replay(a) => replay::run(a),
        Command::Recordings(a) => recordings::run(a),
        Command::Report(a) => report::run(a),
        Command::Sim(a) => sim_jobs::run(a),
        Command::CalibrateReader(a) => calibrate_reader::run(a),
        Command::SetBand(a) => set_band::run(a),
        Command::Export(a) => nir_cli::export(a),
        Command::Import(a) => nir_cli::import(a),
        Command::Ensemble(a) => ensemble::run(a),
        Command::Translate(a) => translate::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The names of commands before they were grouped, kept for a release: `braille chars-report ...`
/// reads as `braille report chars ...`.
const OLD_NAMES: [(&str, [&str; 2]); 10] = [
    ("chars-report", ["report", "chars"]),
    ("words-report", ["report", "words"]),
    ("letters-report", ["report", "letters"]),
    ("icub-report", ["report", "icub"]),
    ("tactile-report", ["report", "tactile"]),
    ("chip-report", ["report", "chip"]),
    ("sim-check", ["sim", "check"]),
    ("label-check", ["sim", "labels"]),
    ("robustness", ["sim", "robustness"]),
    ("sim-dataset", ["sim", "dataset"]),
];

/// `argv` with an old command name written as its group and command.
fn old_names(mut argv: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    if let Some((_, new)) = argv.get(1).and_then(|a| OLD_NAMES.iter().find(|(old, _)| a == old)) {
        argv.splice(1..2, new.iter().map(std::ffi::OsString::from));
    }
    argv
}

/// The error and its causes, each cause once: a cause whose text its error already shows (an
/// I/O error after the file's name) is not repeated.
fn message(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text
}
