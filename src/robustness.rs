//! `braille sim robustness`: each architecture's shipped character classifier against one nuisance
//! of the virtual Evetac at a time (SIMULATED): Markdown, JSON and a PNG per nuisance.

use crate::common::Bar;
use anyhow::{Context, Result};
use experiments::eval::chars::CharModel;
use experiments::eval::robustness::{Nuisance, SweepSpec, sweep};
use sim::{BoardKind, Realism};
use snn::model_file::Arch;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Nuisances to sweep [default: all].
    #[arg(long, value_enum, value_delimiter = ',')]
    nuisances: Vec<Nuisance>,
    /// The preset the other nuisances stay at.
    #[arg(long, value_enum, default_value_t = Realism::Nominal)]
    realism: Realism,
    /// Board scanned (the paper's test board).
    #[arg(long, default_value = "RAB")]
    board: BoardKind,
    /// Scans per board row and level.
    #[arg(long, default_value_t = 4)]
    trials: u64,
    #[arg(long, default_value_t = 8.0)]
    speed: f64,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    /// Scan seed (training used others).
    #[arg(long, default_value_t = 2_000_003)]
    seed: u64,
    /// The folder of the character classifiers swept (`resnet-lite-normaug`, `snn-chars`)
    /// [default: those trained at `--realism`, `models/REALISM/`].
    #[arg(long)]
    models: Option<PathBuf>,
    /// Where to write `robustness.md`, `robustness.json` and `robustness_*.png` [default:
    /// `docs/results/REALISM/`].
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let preset = crate::common::RealismArg { realism: args.realism };
    let models_dir = args.models.clone().unwrap_or_else(|| preset.models_dir());
    let out = args.out.clone().unwrap_or_else(|| preset.results_dir());
    let mut models = Vec::new();
    for (name, arch) in [("ResNet lite NormAug", Arch::Resnet), ("SNN", Arch::Snn)] {
        let path = pipeline::shipped::chars_in(&models_dir, arch);
        models.push((name.to_string(), CharModel::load(&path).with_context(|| format!("loading {}", path.display()))?));
    }
    let spec = SweepSpec {
        base: args.realism,
        nuisances: if args.nuisances.is_empty() { Nuisance::ALL.to_vec() } else { args.nuisances.clone() },
        board: args.board.clone(),
        speed_mm_s: args.speed,
        depth_mm: args.depth,
        trials: args.trials,
        seed: args.seed,
        models_dir: models_dir.display().to_string(),
    };
    let refs: Vec<(String, &CharModel)> = models.iter().map(|(n, m)| (n.clone(), m)).collect();
    let report = sweep(&spec, &refs, &Bar::default())?;
    print!("{}", experiments::reports::figures::write_robustness_report(&report, &out)?);
    Ok(())
}
