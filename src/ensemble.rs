//! `braille ensemble`: trained SNNs of one architecture merged into one network (the members side
//! by side, their readouts summed), which the engine runs and NIR exports like any other.

use anyhow::{Context, Result, bail};
use snn::model_file::{SnnConfig, SnnModel};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A member's model file; give two or more. All must share the architecture, step, readout,
    /// input encoding and classes.
    #[arg(long = "model", required = true)]
    models: Vec<PathBuf>,
    /// Model file to write.
    #[arg(long)]
    out: PathBuf,
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> Result<()> {
    if args.models.len() < 2 {
        bail!("an ensemble needs two or more --model files");
    }
    if args.out.exists() && !args.force {
        bail!("{}: exists; pass --force to replace it", args.out.display());
    }
    let members: Vec<SnnModel> = args.models.iter().map(|p| SnnModel::load(p)).collect::<snn::Result<_>>()?;
    let first = &members[0];
    for (path, m) in args.models.iter().zip(&members).skip(1) {
        let differs = [
            (m.config.network != first.config.network, "architecture"),
            (m.config.dt_us != first.config.dt_us, "step"),
            (m.config.readout != first.config.readout, "readout"),
            (m.preprocess != first.preprocess, "input encoding"),
            (m.classes != first.classes, "classes"),
        ];
        if let Some((_, what)) = differs.iter().find(|(d, _)| *d) {
            bail!("{}: another {what} than {}", path.display(), args.models[0].display());
        }
    }
    let weights: Vec<_> = members.iter().map(|m| m.network.weights()).collect();
    let (spec, merged) = snn::spec::ensemble(&first.config.network, &weights)
        .with_context(|| format!("merging {}", args.models[0].display()))?;
    let network = spec.build(merged)?;
    let provenance = serde_json::json!({
        "ensemble": args.models.iter().zip(&members).map(|(p, m)| serde_json::json!({
            "file": p.file_name().map(|n| n.to_string_lossy().into_owned()),
            "provenance": m.provenance,
        })).collect::<Vec<_>>(),
    });
    let model = SnnModel {
        config: SnnConfig { network: spec, dt_us: first.config.dt_us, readout: first.config.readout },
        network,
        preprocess: first.preprocess.clone(),
        classes: first.classes.clone(),
        provenance,
        // a segmentation network's operating point was calibrated for one member, not the sum
        operating_point: None,
    };
    experiments::train::save_model(&model, &args.out, args.force)?;
    eprintln!("wrote {} ({} members)", args.out.display(), members.len());
    Ok(())
}
