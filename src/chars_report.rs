//! `braille report chars`: the paper's Table I (Raw / Norm / Aug / NormAug) and its depth figure
//! on SIMULATED scans of the RAB board at 8 mm/s, with the SNN beside the ResNet on the same
//! windows, and confusion matrices (`experiments::reports::jobs::chars`). Markdown, JSON and PNG.

use anyhow::Result;
use experiments::reports::jobs::CharsReportJob;

pub fn run(mut job: CharsReportJob) -> Result<()> {
    crate::common::place_defaults(&mut job.place);
    crate::common::finish(experiments::reports::jobs::chars(&job, &crate::common::Bar::default())?)
}
