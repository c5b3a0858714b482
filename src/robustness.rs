//! `braille sim robustness`: each architecture's shipped character classifier against one nuisance
//! of the virtual Evetac at a time (SIMULATED): Markdown, JSON and a PNG per nuisance; with
//! `--final` on the sealed set, the read recorded in docs/protocol.md's ledger.

use anyhow::Result;
use experiments::reports::jobs::{RobustnessReportJob, robustness};

pub fn run(mut job: RobustnessReportJob) -> Result<()> {
    crate::common::place_defaults(&mut job.place);
    crate::common::finish(robustness(&job, &crate::common::Bar::default())?)
}
