//! `braille demo`: the built-in demonstration (`experiments::demo`), written to standard output.

use anyhow::Result;
use experiments::demo::DemoSpec;

pub fn run(mut spec: DemoSpec) -> Result<()> {
    spec.data.get_or_insert_with(|| crate::common::repo_path("data/icub_braille/raw1350"));
    Ok(experiments::demo::run(&spec, &mut std::io::stdout().lock())?)
}
