//! `braille train`: trains a classifier and saves it as a model file. The SNN starts from a
//! recipe (`--recipe NAME|FILE.json|FILE.toml`, `experiments::train::recipe`) whose fields, and
//! the search's options, `--set KEY=VALUE` overrides (`experiments::train::settings`).

use crate::common::{Bar, Epochs};
use anyhow::Result;
use experiments::train::job::{SearchJob, Searched, TrainJob};
use experiments::train::recipe::SnnRecipe;
use experiments::train::search::{FinalModel, SearchObserver, SearchOutcome, Trial, trials_markdown};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    job: TrainJob,
    #[command(flatten)]
    how: SearchJob,
    /// Print the recipe the keys make, as JSON (each field a key), and stop.
    #[arg(long)]
    print_recipe: bool,
    /// Without --data: print the simulated training boards the recipe scans (each board's name,
    /// then its rows as printed), and stop.
    #[arg(long, conflicts_with = "data")]
    print_boards: bool,
    /// No progress bars (a line per epoch still).
    #[arg(long)]
    quiet: bool,
}

/// `argv` with `braille train`'s earlier flags written as `--set`
/// ([`experiments::train::settings::flags_as_keys`]); any other command's arguments pass as they are.
pub fn flags_as_keys(argv: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    // `braille train ...`: the command is the first argument (the binary has no global options)
    if argv.get(1).is_none_or(|a| a != "train") {
        return argv;
    }
    let run_flags: Vec<String> = <Args as clap::Args>::augment_args(clap::Command::new("train"))
        .get_arguments()
        .filter_map(|a| a.get_long().map(str::to_string))
        .collect();
    let mut out = argv[..2].to_vec();
    out.extend(experiments::train::settings::flags_as_keys(&argv[2..], &run_flags));
    out
}

pub fn run(args: Args) -> Result<()> {
    let (job, how) = (&args.job, &args.how);
    let p = job.prepare()?;
    if args.print_recipe {
        if let Some(profile) = &p.profile {
            eprintln!("{profile}");
        }
        println!("{}", serde_json::to_string_pretty(&p.settings.recipe)?);
        eprintln!("search options (keys search.*): {}", serde_json::to_string(&p.settings.search)?);
        return Ok(());
    }
    if args.print_boards {
        for board in corpus::windows::training_boards(&p.settings.recipe.training_scans())? {
            let (rows, spread) = board.rows();
            let kind = if spread { "letters spread over the row" } else { "at the cell spacing" };
            let name = if matches!(board, sim::BoardKind::Text(_)) { "text".into() } else { board.name() };
            println!("# {name} ({} rows, {kind})", rows.len());
            rows.iter().for_each(|row| println!("{row}"));
        }
        return Ok(());
    }
    let mut epochs = Epochs::new(args.quiet);
    if how.wanted() {
        if let Some(profile) = &p.profile {
            eprintln!("{profile}");
        }
        let searched =
            experiments::train::job::search(job, how, &p, &mut TrialLines { quiet: args.quiet }, &mut epochs)?;
        return print_search(job, &searched);
    }
    if job.recipe.is_none()
        && let Some(profile) = &p.profile
    {
        eprintln!("{profile}; the recipe derived from it (--print-recipe shows it)");
    }
    let trained = experiments::train::job::train(job, &p, &mut epochs, &Bar::default())?;
    eprint!("{trained}");
    eprintln!("wrote {} (peak RSS {:.0} MB)", job.out()?.display(), experiments::peak_rss_mb().unwrap_or(f64::NAN));
    Ok(())
}

/// Reports each trial as it ends (and its epochs, unless quiet).
struct TrialLines {
    quiet: bool,
}

impl SearchObserver for TrialLines {
    fn rung_begin(&mut self, rung: usize, rungs: usize, points: usize, epochs: usize) {
        eprintln!("successive halving, rung {rung} of {rungs}: {points} points, at most {epochs} epochs each");
    }
    fn trial_begin(&mut self, trial: usize, of: usize, r: &SnnRecipe) {
        eprintln!("trial {trial}/{of}: {}", r.trial_summary());
    }
    fn epoch(&mut self, e: &learn::train::EpochReport) {
        if !self.quiet {
            let (train, val) = (100.0 * e.train_accuracy, 100.0 * e.val_accuracy);
            eprintln!("  epoch {:>3}: train acc {train:5.1}% | val acc {val:5.1}% | {:.1} s", e.epoch, e.seconds);
        }
    }
    fn chosen(&mut self, w: &Trial, f: &SnnRecipe, seeds: u64) {
        eprintln!(
            "chosen: trial {} (score {:.2}%); training it on the whole training split for {} epochs (averaged over the last {}), seeds 1..={seeds}",
            w.trial,
            100.0 * w.score,
            f.epochs,
            f.average_epochs,
        );
    }
    fn final_model(&mut self, m: &FinalModel) {
        eprintln!("{m}");
    }
    fn trial_end(&mut self, t: &Trial) {
        eprintln!("{t}");
    }
}

/// What a search ended with: its trials' table, and where its report or logs are.
fn print_search(job: &TrainJob, searched: &Searched) -> Result<()> {
    let outcome = match searched {
        Searched::Rule { chosen, scores, outcome } => {
            let name = ["truncated", "exact"];
            eprintln!(
                "the {}-gradient search stands: validation score {:.2}% against {:.2}% ({})",
                name[*chosen],
                100.0 * scores[*chosen],
                100.0 * scores[1 - chosen],
                name[1 - chosen]
            );
            outcome
        }
        Searched::One { outcome, .. } => outcome,
    };
    match (outcome, searched) {
        (SearchOutcome::Shard { trials }, Searched::One { shard, dir, .. }) => {
            println!("{}", trials_markdown(trials));
            eprintln!(
                "shard {shard}: {} trials in {}; when every shard is done: braille train --data {} --collect {} --out {}",
                trials.len(),
                dir.display(),
                job.data.as_deref().unwrap_or(std::path::Path::new("DIR")).display(),
                dir.display(),
                job.out()?.display()
            );
        }
        (SearchOutcome::Done { trials, report, .. }, _) => {
            println!("{}", trials_markdown(trials));
            eprintln!("wrote {}", report.display());
        }
        (SearchOutcome::Shard { .. }, Searched::Rule { .. }) => {}
    }
    Ok(())
}
