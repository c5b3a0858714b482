//! `braille eval`: a trained model's accuracy: on a dataset folder's split (the SNN on the
//! event-driven engine), on simulated character windows (`eval chars`), or reading words from
//! simulated scans (`eval words`).

use crate::common::Bar;
use anyhow::{Context, Result};
use corpus::windows::{CharSetSpec, Task};
use experiments::eval::tactile::SplitChoice;
use experiments::eval::words::WordsSpec;
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
    #[command(flatten)]
    on_chip: ChipArgs,
}

/// A model in a chip's arithmetic (`--chip`), shared by `eval` and `eval chars`.
#[derive(clap::Args)]
pub struct ChipArgs {
    /// Run the model in a chip's arithmetic (docs/chips.md): mapped into its number formats
    /// (integer weights, fixed-point state, decays by bit shifts or integer multiplies), every
    /// sample as the chip computes.
    #[arg(long, value_enum)]
    chip: Option<snn::chip::Chip>,
    /// --chip: how float weights become the chip's integers (Xylo: Rockpool's quantisers; Speck:
    /// Sinabs's one scale per core; Loihi 2: one exponent per layer; the last two `global` only).
    #[arg(long, value_enum, default_value = "global", requires = "chip")]
    quantisation: snn::chip::xylo::Quantisation,
    /// --chip: every neuron every step (`stepped`, the vendor simulator's loop) or only neurons
    /// with state or input (`event-driven`); the two agree bit for bit.
    #[arg(long, value_enum, default_value = "event-driven", requires = "chip")]
    chip_run: snn::chip::xylo::Run,
    /// --chip: also write every sample as the chip ran it (JSON: the mapped specification, the
    /// inputs and every spike), for a spike-for-spike check with the vendor's simulator
    /// (scripts/chips/xylosim_check.py, sinabs_check.py, lava_check.py).
    #[arg(long, requires = "chip")]
    trace: Option<PathBuf>,
}

impl ChipArgs {
    fn choice(&self) -> Option<experiments::eval::chip::ChipChoice> {
        self.chip.map(|chip| experiments::eval::chip::ChipChoice {
            chip,
            quantisation: self.quantisation,
            run: self.chip_run,
        })
    }

    fn write_trace(&self, trace: Option<experiments::eval::chip::ChipTrace>) -> Result<()> {
        if let (Some(path), Some(trace)) = (&self.trace, trace) {
            let json = serde_json::to_vec(&trace)?;
            std::fs::write(path, json).map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
        }
        Ok(())
    }
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
    if let Some(choice) = args.on_chip.choice() {
        return eval_chip(&args, choice, &model_path, &data_dir, split);
    }
    let (report, csv) = experiments::eval::tactile::eval_split(&model_path, &data_dir, split, args.mode)?;
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

fn eval_chip(
    args: &Args,
    choice: experiments::eval::chip::ChipChoice,
    model_path: &std::path::Path,
    data_dir: &std::path::Path,
    split: SplitChoice,
) -> Result<()> {
    let chip = choice.chip;
    let (report, csv, trace) = experiments::eval::chip::eval_split_chip(
        model_path,
        data_dir,
        split,
        choice,
        args.on_chip.trace.is_some(),
        &Bar::default(),
    )?;
    if let Some(path) = &args.predictions {
        std::fs::write(path, csv).map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
    }
    args.on_chip.write_trace(trace)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    let e = &report.eval;
    println!(
        "{} ({} split, {} samples) in {chip}'s arithmetic ({:?} quantisation, weight shifts {:?}, {} run): accuracy {:.2}%; {:.0} synops, {:.0} spikes, {:.0} neuron updates, {:.1} input events per sample",
        e.data,
        e.split,
        e.n,
        choice.quantisation,
        report.weight_shifts,
        e.mode,
        100.0 * e.accuracy,
        e.synops_per_sample,
        e.spikes_per_sample,
        report.neuron_updates_per_sample,
        e.input_events_per_sample
    );
    println!("what the mapping changed:");
    for a in &report.approximations {
        println!("  {a}");
    }
    Ok(())
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
    /// The sensor builds that scan the board: `test` (reported figures), `training` (with a
    /// validation board, for choices) or `validation` (builds held out of training and test, with
    /// a validation board: choices that must hold on a new sensor).
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
    #[arg(long, default_value_t = corpus::world::TEST_SEED)]
    seed: u64,
    #[arg(long)]
    json: bool,
    /// The sensor mount's compliance (um per N) in place of the preset's: 0 for a rigid mount
    /// (no stick-slip), 10 is `nominal`'s, 33 `harsh`'s. The same scans with another mount, to
    /// measure what stick-slip costs (docs/simulator.md).
    #[arg(long)]
    mount_compliance_um_per_n: Option<f64>,
    /// Score on a lab's recordings folder instead of simulated scans (docs/recordings.md): its
    /// `test` scans (or `--role`'s), each labelled by the paper's pipeline from the manifest's
    /// text and commanded speed, one score per commanded speed and depth; the board, speed,
    /// depth, trials, seed and builds options do not apply.
    #[arg(long)]
    recordings: Option<PathBuf>,
    /// --recordings: which role's scans.
    #[arg(long, value_enum, default_value = "test", requires = "recordings")]
    role: corpus::recordings::Role,
    #[command(flatten)]
    realism: crate::common::RealismArg,
    #[command(flatten)]
    on_chip: ChipArgs,
}

fn chars(args: CharsArgs) -> Result<()> {
    let path = match &args.model {
        Some(p) => p.clone(),
        None => pipeline::shipped::chars_in(&args.realism.models_dir(), args.arch),
    };
    if let Some(dir) = &args.recordings {
        let rec = corpus::recordings::Recordings::open(dir)?;
        let scores = experiments::eval::chars::eval_recordings(&path, &rec, args.role, &Bar::default())?;
        if scores.is_empty() {
            anyhow::bail!("{}: no {} scans in the manifest", dir.display(), args.role.name());
        }
        if args.json {
            println!("{}", serde_json::to_string_pretty(&scores)?);
        } else {
            scores.iter().for_each(|s| print!("{s}"));
        }
        return Ok(());
    }
    let spec = CharSetSpec {
        boards: vec![args.board.clone()],
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        task: Task::Chars,
        jitter_ms: 0.0,
        world: args.realism.world(args.sensor_builds).with_mount(args.mount_compliance_um_per_n),
        blank_cells: false,
        sweep: None,
    };
    if let Some(choice) = args.on_chip.choice() {
        let (r, trace) =
            experiments::eval::chars::eval_chip(&path, &spec, choice, args.on_chip.trace.is_some(), &Bar::default())?;
        args.on_chip.write_trace(trace)?;
        if args.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            print!("{}", r.eval);
            println!(
                "in {}'s arithmetic ({:?} quantisation, {:?} run): {:.0} neuron updates per window; what the mapping changed:",
                choice.chip, choice.quantisation, choice.run, r.neuron_updates_per_sample
            );
            for a in &r.approximations {
                println!("  {a}");
            }
        }
        return Ok(());
    }
    let r = experiments::eval::chars::eval(&path, &spec, &Bar::default())?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print!("{r}");
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
    braille: pipeline::code::BrailleCode,
    /// The sensor builds that scan the board: `test` (reported figures), `training` (with a
    /// validation board, for choices) or `validation` (builds held out of training and test, with
    /// a validation board: choices that must hold on a new sensor).
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
    #[arg(long, default_value_t = corpus::world::TEST_SEED)]
    seed: u64,
    #[arg(long, value_enum, default_value = "sliding")]
    snn_runner: SnnRunner,
    /// Run both SNNs (segmentation network and classifier) in a chip's arithmetic (docs/chips.md),
    /// every window from rest as the chip computes it (in place of `--snn-runner`).
    #[arg(long, value_enum)]
    chip: Option<snn::chip::Chip>,
    /// --chip: how float weights become the chip's integers.
    #[arg(long, value_enum, default_value = "global", requires = "chip")]
    quantisation: snn::chip::xylo::Quantisation,
    /// Read a lab's recordings folder instead of simulated scans (docs/recordings.md): its
    /// `test` scans (or `--role`'s), one table per commanded speed and depth; the board, speed,
    /// depth, trials, seed and builds options do not apply (`given` timing hands the reader the
    /// commanded speed).
    #[arg(long)]
    recordings: Option<PathBuf>,
    /// --recordings: which role's scans.
    #[arg(long, value_enum, default_value = "test", requires = "recordings")]
    role: corpus::recordings::Role,
    #[arg(long)]
    json: bool,
    /// The sensor mount's compliance (um per N) in place of the preset's: 0 for a rigid mount
    /// (no stick-slip), 10 is `nominal`'s, 33 `harsh`'s. The same scans with another mount, to
    /// measure what stick-slip costs (docs/simulator.md).
    #[arg(long)]
    mount_compliance_um_per_n: Option<f64>,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

fn words(args: WordsArgs) -> Result<()> {
    let mut files = pipeline::shipped::reader_for(&args.realism.models_dir(), args.arch, args.braille);
    files.segmenter = args.segmenter.clone().unwrap_or(files.segmenter);
    files.classifier = args.classifier.clone().unwrap_or(files.classifier);
    let mut readers = ReaderModels::load(&files.segmenter, &files.classifier, args.snn_runner)?;
    if let Some(chip) = args.chip {
        let on_chip = |m: pipeline::classify::WindowModel, path: &std::path::Path| {
            m.on_chip(chip, args.quantisation).with_context(|| format!("{}: in {chip}'s arithmetic", path.display()))
        };
        readers = ReaderModels {
            segmenter: on_chip(readers.segmenter, &files.segmenter)?,
            classifier: on_chip(readers.classifier, &files.classifier)?,
            cell_grid: readers.cell_grid,
        };
    }
    if let Some(dir) = &args.recordings {
        let rec = corpus::recordings::Recordings::open(dir)?;
        let tables = experiments::eval::words::eval_recordings(
            &rec,
            args.role,
            &readers,
            &files,
            args.timing,
            args.spell,
            &Bar::default(),
        )?;
        if tables.is_empty() {
            anyhow::bail!("{}: no {} scans in the manifest", dir.display(), args.role.name());
        }
        if args.json {
            println!("{}", serde_json::to_string_pretty(&tables)?);
        } else {
            for t in &tables {
                print!("{t}");
            }
        }
        return Ok(());
    }
    let board = corpus::boards::parse_print_board(
        args.board.as_deref().unwrap_or(if args.braille == pipeline::code::BrailleCode::Grade1Letters {
            "EV"
        } else {
            "UEB-SENTENCES"
        }),
        args.braille,
    )?;
    let spec = WordsSpec {
        board: board.kind.clone(),
        speed_mm_s: args.speed,
        speed_variation: args.hand_variation,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        world: args.realism.world(args.sensor_builds).with_mount(args.mount_compliance_um_per_n),
    };
    if args.braille != pipeline::code::BrailleCode::Grade1Letters {
        let r = experiments::eval::ueb::eval_ueb(&board, &spec, &readers, &files, args.timing, &Bar::default())?;
        if args.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            print!("{r}");
        }
        return Ok(());
    }
    let r = experiments::eval::words::eval_words(
        &spec,
        &readers,
        &files,
        args.sensor_builds,
        args.timing,
        args.spell,
        &Bar::default(),
    )?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print!("{r}");
    }
    Ok(())
}
