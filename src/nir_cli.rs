//! `braille export` and `braille import`: trained SNNs to NIR files and back.

use anyhow::{Result, bail};
use snn::model_file::{Readout, SnnConfig, SnnModel};
use snn::neuron::NeuronKind;
use snn::nir::{self, Graph, ImportOptions, ImportReset, SubtractExport, Target};
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatArg {
    Nir,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TargetArg {
    Generic,
    Loihi2,
    Speck,
    Xylo,
    Spinnaker2,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    #[arg(long, value_enum, default_value = "snn")]
    arch: snn::model_file::Arch,
    /// The model file [default: models/snn-raw1350.safetensors].
    #[arg(long)]
    model: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "nir")]
    format: FormatArg,
    #[arg(long)]
    out: PathBuf,
    /// Check the graph against a chip's toolchain rules first.
    #[arg(long, value_enum, default_value = "generic")]
    target: TargetArg,
    /// Write neurons that reset by subtraction as NIR's reset to v_reset (changes the dynamics).
    #[arg(long)]
    subtract_as_reset: bool,
    #[arg(long)]
    force: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ResetArg {
    /// NIR's semantics.
    ToVReset,
    /// Reset by subtraction (what snnTorch's `subtract` means; NIR cannot say it).
    Subtract,
}

#[derive(clap::Args)]
pub struct ImportArgs {
    /// A NIR file (HDF5).
    file: PathBuf,
    /// Model file to write.
    #[arg(long)]
    out: PathBuf,
    /// The engine's step, in microseconds (snnTorch's exporter assumes 100 us).
    #[arg(long, default_value_t = 100)]
    dt_us: i64,
    #[arg(long, value_enum, default_value = "to-v-reset")]
    reset: ResetArg,
    /// Copy the input encoding and class names from this model (for example the one exported).
    #[arg(long)]
    like: Option<PathBuf>,
    #[arg(long)]
    force: bool,
}

fn target(t: TargetArg) -> Target {
    match t {
        TargetArg::Generic => Target::Generic,
        TargetArg::Loihi2 => Target::Loihi2,
        TargetArg::Speck => Target::Speck,
        TargetArg::Xylo => Target::Xylo,
        TargetArg::Spinnaker2 => Target::Spinnaker2,
    }
}

pub fn export(args: ExportArgs) -> Result<()> {
    if args.arch != snn::model_file::Arch::Snn {
        bail!("only SNNs export to NIR; a ResNet is not a spiking network");
    }
    let path = args.model.unwrap_or_else(|| PathBuf::from("models/snn-raw1350.safetensors"));
    let model = SnnModel::load(&path)?;
    nir::check_target(&model.network, target(args.target))
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim_start_matches("<target>: ")))?;
    let how = if args.subtract_as_reset { SubtractExport::AsReset } else { SubtractExport::Refuse };
    let graph = nir::export(&model.network, model.config.dt_us as f64 * 1e-6, how)
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim_start_matches("<export>: ")))?;
    graph.write(&args.out, args.force)?;
    eprintln!(
        "wrote {} ({} nodes, {} edges; NIR {}, dt {} us)",
        args.out.display(),
        graph.nodes.len(),
        graph.edges.len(),
        nir::NIR_VERSION,
        model.config.dt_us
    );
    Ok(())
}

pub fn import(args: ImportArgs) -> Result<()> {
    if args.dt_us <= 0 {
        bail!("--dt-us must be positive");
    }
    let graph = Graph::read(&args.file)?;
    let reset = match args.reset {
        ResetArg::ToVReset => ImportReset::ToVReset,
        ResetArg::Subtract => ImportReset::Subtract,
    };
    let imported = nir::import(&args.file, &graph, &ImportOptions { dt_s: args.dt_us as f64 * 1e-6, reset })?;
    let net = imported.network;
    let readout = match net.layers.last().and_then(|l| l.neurons).map(|p| p.kind) {
        Some(NeuronKind::Li) => Readout::MaxMembrane,
        _ => Readout::SpikeCount,
    };
    let (preprocess, classes) = match &args.like {
        Some(p) => {
            let m = SnnModel::load(p)?;
            (m.preprocess, m.classes)
        }
        None => (serde_json::Value::Null, (0..net.n_outputs()).map(|i| i.to_string()).collect()),
    };
    let model = SnnModel {
        config: SnnConfig { network: net.spec(), dt_us: args.dt_us, readout },
        network: net,
        preprocess,
        classes,
        provenance: serde_json::json!({ "imported_from": args.file.display().to_string(), "nir_version": graph.version }),
    };
    model.save(&args.out, args.force)?;
    eprintln!(
        "wrote {}: {} layers from {} nodes ({})",
        args.out.display(),
        model.network.layers.len(),
        graph.nodes.len(),
        imported
            .layer_nodes
            .iter()
            .map(|(o, n)| format!("{o}{}", n.as_ref().map_or(String::new(), |n| format!("+{n}"))))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
