//! `braille export` and `braille import`: trained SNNs to NIR files and back.

use anyhow::{Result, bail};
use pipeline::network;
use pipeline::shipped::Variant;
use snn::nir::{Convention, ImportReset, Target};
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatArg {
    Nir,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    #[arg(long, value_enum, default_value = "snn")]
    arch: snn::model_file::Arch,
    /// The model file [default: models/icub/snn-raw1350.safetensors].
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
    let path = args.model.unwrap_or_else(|| crate::common::shipped().icub("raw1350", Variant::Trained));
    let (graph, dt_s) = network::export_nir(&path, args.target, args.convention, args.subtract_as_reset)?;
    graph.write(&args.out, args.force)?;
    eprintln!(
        "wrote {} ({} nodes, {} edges; NIR {}, {} convention: import at dt = {} s; target {})",
        args.out.display(),
        graph.nodes.len(),
        graph.edges.len(),
        snn::nir::NIR_VERSION,
        args.convention.name(),
        args.convention.import_dt_s(dt_s),
        args.target.name()
    );
    Ok(())
}

pub fn import(args: ImportArgs) -> Result<()> {
    let (model, imported, graph) = network::import_nir(&args.file, args.dt_us, args.reset, args.like.as_deref())?;
    model.save(&args.out, args.force)?;
    eprintln!(
        "wrote {}: {} layers from {} nodes ({})",
        args.out.display(),
        model.network.layers.len(),
        graph.nodes.len(),
        imported
            .iter()
            .map(|(o, n)| format!("{o}{}", n.as_ref().map_or(String::new(), |n| format!("+{n}"))))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
