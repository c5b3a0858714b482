//! `braille sim`: the simulator's own checks and what it makes besides scans (`braille
//! simulate` makes scans).

use anyhow::Result;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    job: Job,
}

#[derive(clap::Subcommand)]
pub enum Job {
    /// Measure the simulator's physics checks (depth, speed, polarity, geometry, noise, readout).
    Check(crate::sim_check::Args),
    /// Measure the paper's labeling pipeline against the simulator's ground truth.
    Labels(crate::label_check::Args),
    /// Each architecture's character classifier against one simulator nuisance at a time (noise,
    /// misalignment, depth drift, speed, sensor build, mount compliance with stick-slip):
    /// Markdown, JSON, PNG.
    Robustness(experiments::reports::jobs::RobustnessReportJob),
    /// A tactile dataset of another layout (a grid of event taxels under each Braille character)
    /// as a folder in the iCub layout, for `train --data` and `baselines --data`.
    Dataset(crate::sim_dataset::Args),
}

pub fn run(args: Args) -> Result<()> {
    match args.job {
        Job::Check(a) => crate::sim_check::run(a),
        Job::Labels(a) => crate::label_check::run(a),
        Job::Robustness(a) => crate::robustness::run(a),
        Job::Dataset(a) => crate::sim_dataset::run(a),
    }
}
