//! `braille eval`: a trained model's accuracy: on a dataset folder's split (the SNN on the
//! event-driven engine), on simulated character windows (`eval chars`), or reading words from
//! simulated scans (`eval words`).

use crate::common::{Bar, ChipArgs, emit};
use anyhow::{Context, Result};
use corpus::windows::{CharSetSpec, Task};
use experiments::eval::tactile::SplitChoice;
use experiments::eval::words::WordsSpec;
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::code::BrailleCode;
use pipeline::reader::{Spell, TimingMode};
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
    #[command(flatten)]
    on_chip: ChipArgs,
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
    let (Some(data_dir), Some(model_path)) = (&args.data, &args.model) else {
        anyhow::bail!("eval needs --data DIR and --model PATH, or the `chars` or `words` subcommand");
    };
    let split = match args.split {
        SplitArg::Train => SplitChoice::Train,
        SplitArg::Validation => SplitChoice::Validation { fraction: args.val_fraction, seed: args.val_seed },
        SplitArg::Test => SplitChoice::Test,
        SplitArg::All => SplitChoice::All,
    };
    let write_predictions = |csv: String| -> Result<()> {
        if let Some(path) = &args.predictions {
            std::fs::write(path, csv).with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(())
    };
    if let Some(choice) = args.on_chip.choice() {
        let tracing = args.on_chip.trace.is_some();
        let (report, csv, trace) =
            experiments::eval::chip::eval_split_chip(model_path, data_dir, split, choice, tracing, &Bar::default())?;
        write_predictions(csv)?;
        args.on_chip.write_trace(trace)?;
        return emit(&report, args.json);
    }
    let (report, csv) = experiments::eval::tactile::eval_split(model_path, data_dir, split, args.mode)?;
    write_predictions(csv)?;
    emit(&report, args.json)
}

/// What `eval chars` and `eval words` share: which simulated scans, or a lab's recordings.
#[derive(clap::Args)]
pub struct ScanArgs {
    /// The sensor builds that scan the board: `test` (reported figures), `training` (with a
    /// validation board, for choices) or `validation` (builds held out of training and test, with
    /// a validation board: choices that must hold on a new sensor).
    #[arg(long, value_enum, default_value_t = crate::common::SensorBuilds::Test)]
    sensor_builds: crate::common::SensorBuilds,
    /// The scans' depth, mm.
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    /// Scan seed (training used others; the default keeps test scans apart).
    #[arg(long, default_value_t = corpus::world::TEST_SEED)]
    seed: u64,
    /// The sensor mount's compliance (um per N) in place of the preset's: 0 for a rigid mount
    /// (no stick-slip), 10 is `nominal`'s, 33 `harsh`'s. The same scans with another mount, to
    /// measure what stick-slip costs (docs/simulator.md).
    #[arg(long)]
    mount_compliance_um_per_n: Option<f64>,
    /// Score on a lab's recordings folder instead of simulated scans (docs/recordings.md): its
    /// `test` scans (or `--role`'s), one score per commanded speed and depth; the board, speed,
    /// depth, trials, seed and builds options do not apply.
    #[arg(long)]
    recordings: Option<PathBuf>,
    /// --recordings: which role's scans.
    #[arg(long, value_enum, default_value = "test", requires = "recordings")]
    role: corpus::recordings::Role,
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

impl ScanArgs {
    fn world(&self) -> corpus::world::World {
        self.realism.world(self.sensor_builds).with_mount(self.mount_compliance_um_per_n)
    }

    /// `--recordings`: the scores of its role's scans printed (true), an error if none; false without it.
    fn recordings<T: serde::Serialize + std::fmt::Display>(
        &self,
        score: impl FnOnce(&corpus::recordings::Recordings) -> experiments::Result<Vec<T>>,
    ) -> Result<bool> {
        let Some(dir) = &self.recordings else { return Ok(false) };
        let scores = score(&corpus::recordings::Recordings::open(dir)?)?;
        if scores.is_empty() {
            anyhow::bail!("{}: no {} scans in the manifest", dir.display(), self.role.name());
        }
        if self.json {
            println!("{}", serde_json::to_string_pretty(&scores)?);
        } else {
            scores.iter().for_each(|s| print!("{s}"));
        }
        Ok(true)
    }
}

#[derive(clap::Args)]
pub struct CharsArgs {
    #[arg(long, value_enum, default_value = "resnet")]
    arch: Arch,
    /// The model file [default: the architecture's model trained at `--realism`,
    /// resnet-lite-normaug.safetensors or snn-chars.safetensors in models/REALISM/].
    #[arg(long)]
    model: Option<PathBuf>,
    #[arg(long, default_value = "RAB", value_parser = corpus::boards::parse_board)]
    board: BoardKind,
    #[arg(long, default_value_t = 8.0)]
    speed: f64,
    /// Scans per board row.
    #[arg(long, default_value_t = 4)]
    trials: u64,
    /// Score the sealed test set (docs/protocol.md): the test boards printed anew and the sealed
    /// builds, with scans of a seed of their own that no report reads; each read is recorded in
    /// the ledger of docs/protocol.md (or `--ledger`'s file).
    #[arg(long = "final", conflicts_with_all = ["recordings", "seed", "sensor_builds", "mount_compliance_um_per_n"])]
    final_read: bool,
    #[arg(long, requires = "final_read")]
    ledger: Option<PathBuf>,
    #[command(flatten)]
    scans: ScanArgs,
    #[command(flatten)]
    on_chip: ChipArgs,
}

fn chars(args: CharsArgs) -> Result<()> {
    let s = &args.scans;
    let path = args.model.clone().unwrap_or_else(|| pipeline::shipped::chars_in(&s.realism.models_dir(), args.arch));
    if s.recordings(|rec| experiments::eval::chars::eval_recordings(&path, rec, s.role, &Bar::default()))? {
        return Ok(());
    }
    let spec = CharSetSpec {
        boards: vec![args.board.clone()],
        speed_mm_s: args.speed,
        depth_mm: s.depth,
        trials: args.trials,
        seed: if args.final_read { corpus::world::SEALED_STUDY_SEED } else { s.seed },
        task: Task::Chars,
        jitter_ms: 0.0,
        world: if args.final_read { corpus::world::World::sealed(s.realism.realism) } else { s.world() },
        blank_cells: false,
        sweep: None,
    };
    if let Some(choice) = args.on_chip.choice() {
        let tracing = args.on_chip.trace.is_some();
        let (r, trace) = experiments::eval::chars::eval_chip(&path, &spec, choice, tracing, &Bar::default())?;
        args.on_chip.write_trace(trace)?;
        return emit(&r, s.json);
    }
    let r = experiments::eval::chars::eval(&path, &spec, &Bar::default())?;
    if args.final_read {
        let name = path.display();
        let set = format!(
            "eval chars {} {} mm/s {} mm x{}, {}, {name}",
            args.board.name(),
            args.speed,
            s.depth,
            args.trials,
            s.realism.realism
        );
        crate::common::record_sealed(&set, "stdout", args.ledger.clone())?;
    }
    emit(&r, s.json)
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
    /// Board: SAB, UN, RAB, VAL (validation), VAL-WORDS, VAL-LETTERS (validation words and letters),
    /// EV, ALL-LETTERS (every letter at every place), or text:"ANY WORDS"
    /// (`/` starts a new row; long rows wrap). With --braille ueb-g1/ueb-g2 also UEB-SENTENCES
    /// (test) and VAL-UEB (validation), and text: takes any print [default: EV; UEB-SENTENCES
    /// in UEB].
    #[arg(long)]
    board: Option<String>,
    /// The Braille code the board is printed in and the reader reads: `grade1-letters` (the
    /// paper's letters and its readers) or `ueb-g1`/`ueb-g2` (the cell readers of
    /// models/REALISM/ueb/, scored on cells and on the print, exactly and blind to case and
    /// punctuation).
    #[arg(long, value_enum, default_value = "grade1-letters")]
    braille: BrailleCode,
    /// The scans' mean speed, mm/s.
    #[arg(long, default_value_t = 16.0)]
    speed: f64,
    /// Hand-held scans: how far the speed swings around its mean along the row (relative
    /// amplitude; 0 for the arm).
    #[arg(long, default_value_t = 0.0)]
    hand_variation: f64,
    /// Where the reader's speed comes from: `estimated` from the events, `paper` (fixed 10 ms,
    /// 70 ms, 1 s), or `given` (the simulator's true mean speed, or a recording's commanded one:
    /// an oracle).
    #[arg(long, value_enum, default_value_t = TimingMode::Estimated)]
    timing: TimingMode,
    /// Scans per board row.
    #[arg(long, default_value_t = 30)]
    trials: u64,
    #[arg(long, value_enum, default_value = "lexicon")]
    spell: Spell,
    #[arg(long, value_enum, default_value = "sliding")]
    snn_runner: SnnRunner,
    /// The background-activity filter the events pass first (`braille read --denoise`)
    /// [default: the models'].
    #[arg(long)]
    denoise: Option<encoders::denoise::DenoiseChoice>,
    /// Run both SNNs (segmentation network and classifier) in a chip's arithmetic (docs/chips.md),
    /// every window from rest as the chip computes it (in place of `--snn-runner`).
    #[arg(long, value_enum)]
    chip: Option<snn::chip::Chip>,
    /// --chip: how float weights become the chip's integers.
    #[arg(long, value_enum, default_value = "global", requires = "chip")]
    quantisation: snn::chip::xylo::Quantisation,
    #[command(flatten)]
    scans: ScanArgs,
}

fn words(args: WordsArgs) -> Result<()> {
    let s = &args.scans;
    let mut files = pipeline::shipped::reader_for(&s.realism.models_dir(), args.arch, args.braille);
    files.segmenter = args.segmenter.clone().unwrap_or(files.segmenter);
    files.classifier = args.classifier.clone().unwrap_or(files.classifier);
    let mut readers = ReaderModels::load(&files.segmenter, &files.classifier, args.snn_runner)?;
    readers.denoise = encoders::denoise::DenoiseChoice::over(args.denoise, readers.denoise);
    if let Some(chip) = args.chip {
        readers = readers.on_chip(chip, args.quantisation).with_context(|| {
            format!("{} and {}: in {chip}'s arithmetic", files.segmenter.display(), files.classifier.display())
        })?;
    }
    let bar = Bar::default();
    let (timing, spell) = (args.timing, args.spell);
    let recorded = s.recordings(|rec| {
        experiments::eval::words::eval_recordings(rec, s.role, &readers, &files, timing, spell, &bar)
    })?;
    if recorded {
        return Ok(());
    }
    let default_board = if args.braille == BrailleCode::Grade1Letters { "EV" } else { "UEB-SENTENCES" };
    let board = corpus::boards::parse_print_board(args.board.as_deref().unwrap_or(default_board), args.braille)?;
    let spec = WordsSpec {
        board: board.kind.clone(),
        speed_mm_s: args.speed,
        speed_variation: args.hand_variation,
        depth_mm: s.depth,
        trials: args.trials,
        seed: s.seed,
        world: s.world(),
    };
    if args.braille != BrailleCode::Grade1Letters {
        return emit(&experiments::eval::ueb::eval_ueb(&board, &spec, &readers, &files, timing, &bar)?, s.json);
    }
    let r = experiments::eval::words::eval_words(&spec, &readers, &files, s.sensor_builds, timing, spell, &bar)?;
    emit(&r, s.json)
}
