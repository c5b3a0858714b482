//! `braille report tactile`: per tactile dataset, the SNN search's final models beside the
//! conventional networks and linear floors chosen by the same protocol
//! (`experiments::reports::tactile`).

use anyhow::Result;
use experiments::reports::tactile::{TactileSource, write_report};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A dataset as NAME=FOLDER (repeatable). Its SNN is the better by validation score of its
    /// searches under the fixed rule (`experiments::reports::tactile::SnnSearch::under_rule`):
    /// for raw1350 and sim-taxels the `--both-gradients` run `NAME-stepscale` (its logs'
    /// `truncated/` and `exact/`), for others the runs `NAME-warmup` (truncated gradients) and
    /// `NAME-exact`; models under --search, trial logs under --search-logs; its networks and floors `NAME/baselines.json` under
    /// --baselines [default: raw1350 and th10 under data/icub_braille,
    /// sim-taxels=target/sim-taxels, the folder `scripts/search_taxels.sh` generates].
    #[arg(long = "dataset", value_name = "NAME=FOLDER")]
    datasets: Vec<String>,
    /// Folder of the SNN search's final models [default: the shipped ones, `models/search/`].
    /// Where its `ensemble-members/` holds seeds 4 and on of the standing search's recipe
    /// (`scripts/ensembles.sh`), seed ensembles of three are scored beside the SNN.
    #[arg(long)]
    search: Option<PathBuf>,
    /// Folder of the SNN searches' trial logs, one folder per search run [default:
    /// `docs/results/search`].
    #[arg(long)]
    search_logs: Option<PathBuf>,
    /// Folder of `braille baselines --search --eval-test --out` results, one folder per dataset.
    #[arg(long, default_value = "docs/results/baselines")]
    baselines: PathBuf,
    /// Where to write `tactile.md` and `tactile.json`.
    #[arg(long, default_value = "docs/results")]
    out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let search = a.search.unwrap_or_else(|| crate::common::shipped().search_dir());
    let logs = a.search_logs.unwrap_or_else(|| crate::common::repo_path("docs/results/search"));
    let datasets = if a.datasets.is_empty() {
        vec![
            "raw1350=data/icub_braille/raw1350".to_string(),
            "th10=data/icub_braille/th10".into(),
            "sim-taxels=target/sim-taxels".into(),
        ]
    } else {
        a.datasets
    };
    let sources = datasets
        .iter()
        .map(|d| TactileSource::parse(d, &search, &logs, &a.baselines))
        .collect::<experiments::Result<Vec<_>>>()?;
    print!("{}", write_report(&sources, &a.out)?);
    Ok(())
}
