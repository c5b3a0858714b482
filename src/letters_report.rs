//! `braille report letters`: every letter at every place in a row, read by both architectures
//! from SIMULATED scans of the all-letters board over speed and depth (Markdown and JSON;
//! `experiments::reports::jobs::letters`).

use anyhow::Result;
use experiments::reports::jobs::LettersReportJob;

pub fn run(mut job: LettersReportJob) -> Result<()> {
    crate::common::place_defaults(&mut job.place);
    crate::common::finish(experiments::reports::jobs::letters(&job, &crate::common::Bar::default())?)
}
