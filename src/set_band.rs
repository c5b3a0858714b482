//! `braille set-band`: a character classifier's windows centred in a band of rows wider than its
//! crop from now on, its weights unchanged (`pipeline::input::CharInput::band`): a row the
//! board's yaw moves past the crop is centred back whole. The provenance records the change.

use anyhow::{Context, Result, bail};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The model file (a character classifier or segmentation network of either architecture,
    /// with a centring input), rewritten in place.
    model: PathBuf,
    /// The band's pooled rows of the labeler's grid, first and last plus one (holding the crop's
    /// rows), or `none` to centre in the crop's rows again.
    #[arg(long)]
    rows: String,
}

pub fn run(args: Args) -> Result<()> {
    let band = match args.rows.as_str() {
        "none" => None,
        rows => {
            let parsed: Option<Vec<usize>> = rows.split(',').map(|r| r.trim().parse().ok()).collect();
            let Some([first, end]) = parsed.and_then(|p| <[usize; 2]>::try_from(p).ok()) else {
                bail!("--rows {rows:?}: two pooled rows, first and last plus one (e.g. 12,100), or none");
            };
            let band = experiments::train::resnet::crop_rows(Some([first, end]));
            Some(band.with_context(|| format!("--rows {rows:?}"))?)
        }
    };
    let mut model = pipeline::models::load(&args.model)?;
    model.set_band(band.clone(), &args.model)?;
    model.save(&args.model, true)?;
    match band {
        Some(b) => eprintln!("{}: windows centred in pooled rows {b:?}", args.model.display()),
        None => eprintln!("{}: windows centred in the crop's rows", args.model.display()),
    }
    Ok(())
}
