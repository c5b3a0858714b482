//! `braille calibrate-reader`: a segmentation network's operating point (threshold, shortest
//! segment) chosen on the validation words, written as Markdown and JSON, and with `--write`
//! into the network's model file, where every reader of it reads it. With `--braille ueb-g1|ueb-g2`
//! the cell readers' network (models/REALISM/ueb/, shared by both architectures) on the validation
//! sentences, one point for both (`experiments::eval::calibrate::job`).

use crate::common::Bar;
use anyhow::Result;
use experiments::eval::calibrate::job::CalibrateJob;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    job: CalibrateJob,
    /// Sweep nothing: record the point chosen by an earlier run (its `operating_point_ARCH.json`)
    /// in the segmentation network's model file.
    #[arg(long, conflicts_with = "write")]
    apply: Option<PathBuf>,
}

pub fn run(mut args: Args) -> Result<()> {
    let job = &mut args.job;
    let shipped = crate::common::shipped();
    if let Some(json) = &args.apply {
        // the segmentation network the point is for: the architecture's, or the cell readers' shared one
        let files = pipeline::shipped::reader_for(&job.models_dir(&shipped), job.arch, job.braille);
        let segmenter = job.segmenter.clone().unwrap_or(files.segmenter);
        let point = experiments::eval::calibrate::chosen_in(json)?;
        experiments::eval::calibrate::record(&segmenter, &point)?;
        let (t, m) = (point.present_threshold, point.min_frames);
        println!("recorded in {}: threshold {t}, {m} frames", segmenter.display());
        return Ok(());
    }
    let results = crate::common::RealismArg { realism: job.realism }.results_dir();
    let ueb = job.braille != pipeline::code::BrailleCode::Grade1Letters;
    job.out.get_or_insert(if ueb { results.join("ueb") } else { results });
    print!("{}", experiments::eval::calibrate::job::run(job, &shipped, &Bar::default())?);
    Ok(())
}
