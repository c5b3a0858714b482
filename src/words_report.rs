//! `braille report words`: the paper's speed table on SIMULATED EV scans for both architectures,
//! with and without spelling (Markdown, JSON and a plot); with `--braille ueb-g1|ueb-g2`, the UEB
//! readers' cells and contracted sentences against speed (`experiments::reports::jobs::words`).

use anyhow::Result;
use experiments::reports::jobs::WordsReportJob;

pub fn run(mut job: WordsReportJob) -> Result<()> {
    crate::common::place_defaults(&mut job.place);
    crate::common::finish(experiments::reports::jobs::words(&job, &crate::common::Bar::default())?)
}
