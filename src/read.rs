//! `braille read`: the words in an event stream (a file, standard input or a live AEDAT 4.0
//! network stream, as it arrives), read
//! by the segmentation network, a character classifier (the ResNet or the SNN) and the temporal
//! filter, then spell-corrected.

use anyhow::Result;
use encoders::Resolution;
use encoders::formats::{self, OpenOptions};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, Timing, TimingMode};
use snn::model_file::Arch;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Event file (.aedat4, .csv, .npy), `-` for standard input, or `tcp://HOST:PORT` for a live
    /// sensor's AEDAT 4.0 network stream (DV's TCP output, dv-processing's NetworkWriter,
    /// `braille replay`); streams are read as they arrive.
    file: PathBuf,
    #[command(flatten)]
    live: crate::common::LiveArgs,
    #[arg(long, value_enum, default_value = "snn")]
    arch: Arch,
    #[arg(long, value_enum, default_value = "lexicon")]
    spell: Spell,
    /// The Braille code of the print: `grade1-letters` (the paper's letters and its readers) or
    /// `ueb-g1`/`ueb-g2` (the cell readers of models/nominal/ueb/, each word's cells
    /// back-translated to print).
    #[arg(long, value_enum, default_value = "grade1-letters")]
    braille: pipeline::code::BrailleCode,
    /// Where the scanning speed comes from: `estimated` from the events themselves, `paper` (the
    /// paper's fixed 10 ms bins, 70 ms and 1 s), or `given` with --speed.
    #[arg(long, value_enum, default_value_t = TimingMode::Estimated)]
    timing: TimingMode,
    /// Scanning speed in mm/s: a hint the estimate replaces (estimated timing), or the speed to
    /// read at (given timing). Nothing is read from a ground-truth file.
    #[arg(long)]
    speed: Option<f64>,
    /// Segmentation network [default: the architecture's shipped one].
    #[arg(long)]
    segmenter: Option<PathBuf>,
    /// Character classifier [default: the architecture's shipped one].
    #[arg(long)]
    model: Option<PathBuf>,
    /// How the SNN reads each frame's window: `sliding` shares the first layer's work between
    /// overlapping windows (the same output), `engine` runs each window on the event-driven engine.
    #[arg(long, value_enum, default_value = "sliding")]
    snn_runner: SnnRunner,
    /// The sensor's resolution, WIDTHxHEIGHT [default: what the file declares, else 640x480].
    #[arg(long)]
    resolution: Option<Resolution>,
    /// The background-activity filter the events pass first (`encoders::denoise`: `dv-lab`,
    /// `dv-processing[:WINDOW_US]`, `off`) [default: the one the models were trained behind].
    #[arg(long)]
    denoise: Option<encoders::denoise::DenoiseChoice>,
    /// JSON Lines: one object per word as it completes, then a summary object.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let timing = Timing::from_mode(args.timing, args.speed)?;
    let pipeline::shipped::ReaderFiles { segmenter: ds, classifier: dc } =
        pipeline::shipped::reader_for(&crate::common::default_models_dir(), args.arch, args.braille);
    let mut readers = ReaderModels::load(
        args.segmenter.as_deref().unwrap_or(&ds),
        args.model.as_deref().unwrap_or(&dc),
        args.snn_runner,
    )?;
    readers.denoise = encoders::denoise::DenoiseChoice::over(args.denoise, readers.denoise);
    let speller = pipeline::reader::Speller::in_code(args.spell, args.braille)?;
    let options = OpenOptions { resolution: args.resolution, stream_id: None };
    let mut source = formats::open_named(&args.file, &options, &args.live.options())?;
    let resolution = args.resolution.or(source.info().resolution).unwrap_or(Resolution::DVXPLORER);
    let stdout = std::io::stdout();
    let json = args.json;
    let mut on_word = |w: &pipeline::reader::ReadWord| -> pipeline::Result<()> {
        let mut lock = stdout.lock();
        let line = if json { serde_json::to_string(w).expect("words serialise") } else { w.to_string() };
        let io = |source| pipeline::Error::Io { path: "standard output".into(), source };
        writeln!(lock, "{line}").map_err(io)?;
        lock.flush().map_err(io)
    };
    let name = args.file.display().to_string();
    let s =
        pipeline::source::read_source(source.as_mut(), &name, &readers, timing, resolution, &speller, &mut on_word)?;
    if args.json {
        println!("{}", serde_json::to_string(&s)?);
    } else {
        print!("{s}");
    }
    Ok(())
}
