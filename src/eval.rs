//! `braille eval`: a trained model's accuracy: on a dataset folder's split (the SNN on the
//! event-driven engine), on simulated character windows (`eval chars`), or reading words from
//! simulated scans (`eval words`).

use crate::common::Bar;
use anyhow::Result;
use experiments::datasets::{CharSetSpec, Task};
use experiments::tactile::SplitChoice;
use experiments::words::WordsSpec;
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::Spell;
use pipeline::reader::TimingMode;
use sim::BoardKind;
use snn::engine::Mode;
use snn::model_file::Arch;
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SplitArg {
    Train,
    /// The validation hold-out of the train split that `braille train` kept with the same
    /// `--val-fraction` and `--val-seed`.
    Validation,
    Test,
    All,
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct Args {
    #[command(subcommand)]
    what: Option<What>,
    /// A dataset folder in the iCub Braille layout.
    #[arg(long, required = true)]
    data: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "test")]
    split: SplitArg,
    /// `--split validation`: the share of the train split held out (as `braille train --val-fraction`).
    #[arg(long, default_value_t = 0.1)]
    val_fraction: f64,
    /// `--split validation`: the hold-out's seed (as `braille train --val-seed`, by default its `--seed`).
    #[arg(long, default_value_t = 1)]
    val_seed: u64,
    /// The model file.
    #[arg(long, required = true)]
    model: Option<PathBuf>,
    /// Engine mode: `stepped` reproduces the trained network exactly; `async` fires at threshold
    /// crossings (LIF and IF layers only).
    #[arg(long, value_enum, default_value = "stepped")]
    mode: Mode,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// Also write each sample's truth, prediction and readout (CSV: the split's samples in file
    /// order), for confusion analysis or combining models.
    #[arg(long)]
    predictions: Option<PathBuf>,
}

#[derive(clap::Subcommand)]
pub enum What {
    /// A character classifier on simulated scans of a board (SIMULATED data).
    Chars(CharsArgs),
    /// Word reading on simulated scans of a board: the paper's four conditional metrics (SIMULATED data).
    Words(WordsArgs),
}

pub fn run(args: Args) -> Result<()> {
    match args.what {
        Some(What::Chars(a)) => return chars(a),
        Some(What::Words(a)) => return words(a),
        None => {}
    }
    let (Some(data_dir), Some(model_path)) = (args.data.clone(), args.model.clone()) else {
        anyhow::bail!("eval needs --data DIR and --model PATH, or the `chars` or `words` subcommand");
    };
    let split = match args.split {
        SplitArg::Train => SplitChoice::Train,
        SplitArg::Validation => SplitChoice::Validation { fraction: args.val_fraction, seed: args.val_seed },
        SplitArg::Test => SplitChoice::Test,
        SplitArg::All => SplitChoice::All,
    };
    let (report, csv) = experiments::tactile::eval_split(&model_path, &data_dir, split, args.mode)?;
    if let Some(path) = &args.predictions {
        std::fs::write(path, csv).map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!(
            "{} ({} split, {} samples): accuracy {:.2}% ({} engine); {:.0} synops, {:.0} spikes, {:.1} input events per sample",
            report.data,
            report.split,
            report.n,
            100.0 * report.accuracy,
            report.mode,
            report.synops_per_sample,
            report.spikes_per_sample,
            report.input_events_per_sample
        );
    }
    Ok(())
}

#[derive(clap::Args)]
pub struct CharsArgs {
    #[arg(long, value_enum, default_value = "resnet")]
    arch: Arch,
    /// The model file [default: the architecture's model trained at `--realism`,
    /// resnet-lite-normaug.safetensors or snn-chars.safetensors in models/ at `clean`, in
    /// models/REALISM/ beyond].
    #[arg(long)]
    model: Option<PathBuf>,
    #[arg(long, default_value = "RAB", value_parser = experiments::datasets::parse_board)]
    board: BoardKind,
    /// The sensor builds that scan the board: `test` (reported figures) or `training` (with a
    /// validation board, for choices).
    #[arg(long, value_enum, default_value_t = crate::common::SensorBuilds::Test)]
    sensor_builds: crate::common::SensorBuilds,
    #[arg(long, default_value_t = 8.0)]
    speed: f64,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    /// Scans per board row.
    #[arg(long, default_value_t = 4)]
    trials: u64,
    /// Scan seed (training used seeds from its own; the default keeps test scans apart).
    #[arg(long, default_value_t = experiments::datasets::TEST_SEED)]
    seed: u64,
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

fn chars(args: CharsArgs) -> Result<()> {
    let path = match &args.model {
        Some(p) => p.clone(),
        None => {
            let shipped = experiments::chars::default_path(args.arch);
            args.realism.models_dir().join(shipped.file_name().unwrap_or_default())
        }
    };
    let spec = CharSetSpec {
        boards: vec![args.board.clone()],
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        task: Task::Chars,
        jitter_ms: 0.0,
        world: args.realism.world(args.sensor_builds),
        blank_cells: false,
    };
    let r = experiments::chars::eval(&path, &spec, &Bar::default())?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        println!(
            "SIMULATED {} at {} mm/s, {} mm: {} windows from {} scans ({} skipped): {} accuracy {:.2}%, macro F1 {:.3}, loss {:.3}{}",
            r.board,
            r.speed_mm_s,
            r.depth_mm,
            r.score.n,
            r.scans,
            r.skipped_scans,
            r.arch,
            100.0 * r.score.accuracy,
            r.score.macro_f1,
            r.score.loss,
            r.score.accuracy_async.map_or(String::new(), |a| format!(" (async engine {:.2}%)", 100.0 * a))
        );
    }
    Ok(())
}

#[derive(clap::Args)]
pub struct WordsArgs {
    #[arg(long, value_enum, default_value = "snn")]
    arch: Arch,
    /// The segmentation network [default: the architecture's, `snn-segment` or
    /// `resnet-tiny-segment`, in the realism's models folder]. Either architecture's, to read
    /// with one architecture's segmentation and the other's classifier.
    #[arg(long)]
    segmenter: Option<PathBuf>,
    /// The character classifier [default: the architecture's, `snn-words` or
    /// `resnet-lite-normaug-words`, in the realism's models folder].
    #[arg(long)]
    classifier: Option<PathBuf>,
    /// Board: SAB, UN, RAB, VAL (validation), VAL-WORDS (validation words), EV, or text:"ANY WORDS"
    /// (`/` starts a new row; long rows wrap).
    #[arg(long, default_value = "EV", value_parser = experiments::datasets::parse_board)]
    board: BoardKind,
    /// The sensor builds that scan the board: `test` (reported figures) or `training` (with a
    /// validation board, for choices).
    #[arg(long, value_enum, default_value_t = crate::common::SensorBuilds::Test)]
    sensor_builds: crate::common::SensorBuilds,
    /// The scans' mean speed, mm/s.
    #[arg(long, default_value_t = 16.0)]
    speed: f64,
    /// Hand-held scans: how far the speed swings around its mean along the row (relative
    /// amplitude; 0 for the arm).
    #[arg(long, default_value_t = 0.0)]
    hand_variation: f64,
    /// Where the reader's speed comes from: `estimated` from the events, `paper` (fixed 10 ms,
    /// 70 ms, 1 s), or `given` (the simulator's true mean speed: an oracle).
    #[arg(long, value_enum, default_value_t = TimingMode::Estimated)]
    timing: TimingMode,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    /// Scans per board row.
    #[arg(long, default_value_t = 30)]
    trials: u64,
    #[arg(long, value_enum, default_value = "lexicon")]
    spell: Spell,
    /// Scan seed (training used others).
    #[arg(long, default_value_t = experiments::datasets::TEST_SEED)]
    seed: u64,
    #[arg(long, value_enum, default_value = "sliding")]
    snn_runner: SnnRunner,
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

fn words(args: WordsArgs) -> Result<()> {
    let (s, c) = experiments::words::default_models(args.arch, &args.realism.models_dir());
    let s_path = args.segmenter.clone().unwrap_or(s);
    let c_path = args.classifier.clone().unwrap_or(c);
    let readers = ReaderModels::load(&s_path, &c_path, args.snn_runner)?;
    let spec = WordsSpec {
        board: args.board.clone(),
        speed_mm_s: args.speed,
        speed_variation: args.hand_variation,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        world: args.realism.world(args.sensor_builds),
    };
    let r = experiments::words::eval_words(&spec, &readers, args.timing, args.spell, &Bar::default())?;
    let s = &r.score;
    if args.json {
        // which networks read, and which sensor builds scanned: a mixed pair or a validation run
        // names itself
        let mut v = serde_json::to_value(&r)?;
        v["segmenter"] = serde_json::json!(s_path.display().to_string());
        v["classifier"] = serde_json::json!(c_path.display().to_string());
        v["operating_point"] = serde_json::to_value(readers.operating_point())?;
        v["sensor_builds"] = serde_json::json!(
            clap::ValueEnum::to_possible_value(&args.sensor_builds).map(|v| v.get_name().to_string())
        );
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        let p = readers.operating_point();
        println!(
            "models: {} + {} (segmentation read above {}, characters from {} frames{})",
            s_path.display(),
            c_path.display(),
            p.present_threshold,
            p.min_frames,
            if p.calibration.is_null() { ", the paper's point" } else { ", calibrated" }
        );
        println!(
            "SIMULATED {} at {} mm/s{}, {} mm, {} lines, {} architecture, {} timing (speed error median {:+.1}%, mean absolute {:.1}% over {} characters), spelling {:?}: word accuracy {:.3} over all printed words, WER {:.3}, CER {:.3}; the paper's conditional metrics: words per line {:.3}, letters per word {:.3}, correct words {:.3}, correct letters {:.3}; read {:.1} s of stream in {:.2} s",
            r.board,
            args.speed,
            if args.hand_variation > 0.0 {
                format!(" hand-held ±{:.0}%", 100.0 * args.hand_variation)
            } else {
                String::new()
            },
            args.depth,
            s.lines,
            s.arch,
            args.timing,
            100.0 * s.speed_error.median,
            100.0 * s.speed_error.mean_abs,
            s.speed_error.chars,
            args.spell,
            r.word_accuracy,
            r.word_error_rate,
            r.char_error_rate,
            r.words_per_line,
            r.letters_per_word,
            r.correct_words,
            r.correct_letters,
            s.stream_s,
            s.read_s
        );
    }
    Ok(())
}
