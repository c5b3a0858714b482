//! `braille export` and `braille import`: trained SNNs to NIR files and back.

use anyhow::{Result, bail};
use snn::model_file::{Readout, SnnConfig, SnnModel};
use snn::nir::{self, Convention, ExportOptions, Graph, ImportOptions, ImportReset, SubtractExport, Target};
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatArg {
    Nir,
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
    target: Target,
    /// How time constants and input scales are written, for the importer that will read the file:
    /// `nir` (the model's step, snnTorch's layout), `snntorch` (snnTorch 1.0's fixed 100 us step),
    /// `norse` (unit `r` and `w_in`, the scales folded into the weights). docs/nir.md.
    #[arg(long, value_enum, default_value = "nir")]
    convention: Convention,
    /// Write neurons that reset by subtraction as NIR's reset to v_reset (changes the dynamics).
    #[arg(long)]
    subtract_as_reset: bool,
    #[arg(long)]
    force: bool,
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
    reset: ImportReset,
    /// Copy the input encoding and class names from this model (for example the one exported).
    #[arg(long)]
    like: Option<PathBuf>,
    #[arg(long)]
    force: bool,
}

pub fn export(args: ExportArgs) -> Result<()> {
    if args.arch != snn::model_file::Arch::Snn {
        bail!("only SNNs export to NIR; a ResNet is not a spiking network");
    }
    let path = args.model.unwrap_or_else(|| PathBuf::from("models/snn-raw1350.safetensors"));
    let model = SnnModel::load(&path)?;
    nir::check_target(&model.network, args.target)
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim_start_matches("<target>: ")))?;
    let dt_s = model.config.dt_us as f64 * 1e-6;
    let subtract = if args.subtract_as_reset { SubtractExport::AsReset } else { SubtractExport::Refuse };
    let graph = nir::export(&model.network, &ExportOptions { dt_s, subtract, convention: args.convention })
        .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim_start_matches("<export>: ")))?;
    graph.write(&args.out, args.force)?;
    eprintln!(
        "wrote {} ({} nodes, {} edges; NIR {}, {} convention: import at dt = {} s; target {})",
        args.out.display(),
        graph.nodes.len(),
        graph.edges.len(),
        nir::NIR_VERSION,
        args.convention.name(),
        args.convention.import_dt_s(dt_s),
        args.target.name()
    );
    Ok(())
}

pub fn import(args: ImportArgs) -> Result<()> {
    if args.dt_us <= 0 {
        bail!("--dt-us must be positive");
    }
    let graph = Graph::read(&args.file)?;
    let imported =
        nir::import(&args.file, &graph, &ImportOptions { dt_s: args.dt_us as f64 * 1e-6, reset: args.reset })?;
    let net = imported.network;
    let readout = Readout::implied_by(&net);
    // `--like`: the model's input, classes and reader operating point (a twin reads as it does)
    let (preprocess, classes, operating_point) = match &args.like {
        Some(p) => {
            let m = SnnModel::load(p)?;
            (m.preprocess, m.classes, m.operating_point)
        }
        None => (serde_json::Value::Null, (0..net.n_outputs()).map(|i| i.to_string()).collect(), None),
    };
    let model = SnnModel {
        config: SnnConfig { network: net.spec(), dt_us: args.dt_us, readout },
        network: net,
        preprocess,
        classes,
        provenance: serde_json::json!({ "imported_from": args.file.display().to_string(), "nir_version": graph.version }),
        operating_point,
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
