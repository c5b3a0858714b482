//! `braille report words`: the paper's speed table on SIMULATED EV scans for both architectures,
//! with and without spelling (Markdown, JSON and a plot); with `--braille ueb-g1|ueb-g2`, the UEB
//! readers' cells and contracted sentences against speed.

use crate::common::Bar;
use anyhow::Result;
use experiments::reports::words::{WordsReportSpec, words_report};
use pipeline::reader::TimingMode;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Where to write `words.md`, `words.json` and `words_speed.png` [default:
    /// docs/results/REALISM/].
    #[arg(long)]
    out: Option<PathBuf>,
    /// The folder of the reading models (`snn-segment`, `snn-words`, `resnet-tiny-segment`,
    /// `resnet-lite-normaug-words`) [default: those trained at `--realism`, `models/REALISM/`
    /// (`REALISM=nominal bash scripts/words.sh`)].
    #[arg(long)]
    models: Option<PathBuf>,
    /// Scans per row and speed [default: 30, the paper's, on EV; 3 on the UEB sentences].
    #[arg(long)]
    trials: Option<u64>,
    /// Speeds of the arm, mm/s [default: 8,16,24,32,48,64; 8,16,32 in UEB].
    #[arg(long, value_delimiter = ',')]
    speeds: Option<Vec<f64>>,
    /// The Braille code: `grade1-letters` (the paper's speed table on EV), or `ueb-g1`/`ueb-g2`:
    /// the cell readers of models/REALISM/ueb/ on every cell of RCB (`--cell-trials` scans a
    /// row at 8 mm/s, 1.5 mm) and on UEB-SENTENCES at `--speeds` (`ueb.md`, `ueb.json`,
    /// `ueb_speed.png` in `--out`/ueb/).
    #[arg(long, value_enum, default_value = "grade1-letters")]
    braille: pipeline::code::BrailleCode,
    /// UEB: scans per row of the cell board.
    #[arg(long, default_value_t = 30)]
    cell_trials: u64,
    /// UEB: the readers keep the classifier's column for cells of one dot column (no cell grid,
    /// `pipeline::grid`), to measure what the grid does.
    #[arg(long)]
    no_cell_grid: bool,
    /// UEB: the validation boards (VCB, VAL-UEB) scanned by the training builds, for choices,
    /// in place of the test boards (`ueb_validation.*`).
    #[arg(long)]
    validation: bool,
    /// Mean speeds of hand-held scans, mm/s (none: `--hand-speeds` with no value).
    #[arg(long, value_delimiter = ',', num_args = 0.., default_value = "16,32")]
    hand_speeds: Vec<f64>,
    /// How far a hand-held scan's speed swings around its mean (relative amplitude).
    #[arg(long, default_value_t = 0.4)]
    hand_variation: f64,
    /// Where the reader's speed comes from; every timing reads the same scans [default:
    /// estimated,paper,given; estimated in UEB, which reads with one].
    #[arg(long, value_enum, value_delimiter = ',')]
    timings: Option<Vec<TimingMode>>,
    /// Rows of a text board of words no training row used, read at the arm's speeds (0: none).
    #[arg(long, default_value_t = 4)]
    unseen_rows: usize,
    /// Scans per row of the unseen words.
    #[arg(long, default_value_t = 10)]
    unseen_trials: u64,
    /// The scans' depth, mm [default: 1.5 on EV, 1.0 on the UEB sentences].
    #[arg(long)]
    depth: Option<f64>,
    #[arg(long, default_value_t = corpus::world::TEST_SEED)]
    seed: u64,
    #[command(flatten)]
    realism: crate::common::RealismArg,
}

pub fn run(args: Args) -> Result<()> {
    let models = args.models.clone().unwrap_or_else(|| args.realism.models_dir());
    if args.braille != pipeline::code::BrailleCode::Grade1Letters {
        return ueb(args, &models);
    }
    let world = args.realism.test_world();
    let spec = WordsReportSpec {
        speeds_mm_s: args.speeds.unwrap_or_else(|| vec![8.0, 16.0, 24.0, 32.0, 48.0, 64.0]),
        hand_speeds_mm_s: args.hand_speeds,
        hand_speed_variation: args.hand_variation,
        timings: args.timings.unwrap_or_else(|| vec![TimingMode::Estimated, TimingMode::Paper, TimingMode::Given]),
        depth_mm: args.depth.unwrap_or(1.5),
        trials: args.trials.unwrap_or(30),
        seed: args.seed,
        world,
        unseen_rows: args.unseen_rows,
        unseen_trials: args.unseen_trials,
    };
    let r = words_report(&models, &spec, &Bar::default())?;
    let out = args.out.clone().unwrap_or_else(|| args.realism.results_dir());
    experiments::reports::figures::write_words_report(&r, &out)?;
    eprintln!("wrote {}/words.md, words.json, words_speed.png", out.display());
    Ok(())
}

/// `--braille ueb-g1|ueb-g2`: the UEB readers' report.
fn ueb(args: Args, models: &std::path::Path) -> Result<()> {
    use corpus::boards::HeldOut;
    use experiments::reports::ueb::{UebReportSpec, ueb_report};
    let (held_out, builds) = if args.validation {
        (HeldOut::Validation, crate::common::SensorBuilds::Training)
    } else {
        (HeldOut::Test, crate::common::SensorBuilds::Test)
    };
    let timings = args.timings.clone().unwrap_or_else(|| vec![TimingMode::Estimated]);
    let [timing] = timings[..] else {
        anyhow::bail!("--braille {}: one --timings (the UEB report reads with one)", args.braille);
    };
    let spec = UebReportSpec {
        code: args.braille,
        held_out,
        cell_speed_mm_s: 8.0,
        cell_depth_mm: 1.5,
        cell_trials: args.cell_trials,
        speeds_mm_s: args.speeds.unwrap_or_else(|| vec![8.0, 16.0, 32.0]),
        depth_mm: args.depth.unwrap_or(1.0),
        trials: args.trials.unwrap_or(3),
        timing,
        cell_grid: !args.no_cell_grid,
        seed: args.seed,
        world: args.realism.world(builds),
    };
    let r = ueb_report(models, &spec, &Bar::default())?;
    let out = args.out.clone().unwrap_or_else(|| args.realism.results_dir()).join("ueb");
    experiments::reports::figures::write_ueb_report(&r, &out)?;
    print!("{}", experiments::reports::ueb::markdown(&r));
    eprintln!("wrote {}", out.display());
    Ok(())
}
