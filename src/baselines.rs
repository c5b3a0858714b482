//! `braille baselines`: the non-spiking floors of a tactile dataset folder, on the SNN search's
//! validation hold-out (`experiments::train::baselines`); with `--search`, the conventional
//! networks chosen by the same protocol (`experiments::train::networks`) in the same table.

use crate::common::Epochs;
use anyhow::{Result, bail};
use encoders::dataset::Dataset;
use experiments::train::baselines::BaselinesTable;
use experiments::train::fit::{EvalTest, TactileData};
use experiments::train::networks::{NetworkFinal, NetworkObserver, NetworkSearch, NetworkTrial};
use experiments::train::search::{DataProfile, derived_recipe};
use learn::temporal::{TemporalConfig, TemporalKind};
use std::path::PathBuf;

#[derive(Clone, Copy, clap::ValueEnum)]
enum Network {
    Gru,
    Lstm,
    Tcn,
}

#[derive(clap::Args)]
pub struct Args {
    /// A dataset folder in the iCub Braille layout (any channel and class count).
    #[arg(long)]
    data: PathBuf,
    /// Sampling period of analog data, in microseconds.
    #[arg(long, default_value_t = 25_000)]
    period_us: i64,
    /// Share of the training split held out to choose each model's settings.
    #[arg(long, default_value_t = 0.2)]
    val_fraction: f64,
    #[arg(long, default_value_t = 1)]
    val_seed: u64,
    /// Also the conventional networks (GRU, LSTM, temporal CNN over the binned events), each
    /// chosen on validation from a small grid and retrained on the whole training split per seed.
    #[arg(long)]
    search: bool,
    /// --search: the networks, their trials taken in turn in this order (the cheapest first, so
    /// that a budget cuts the dearest).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "tcn,gru,lstm")]
    networks: Vec<Network>,
    /// --search: final models' seeds, 1..=K.
    #[arg(long, default_value_t = 3)]
    seeds: u64,
    /// --search: epochs per trial (the best validation epoch kept); as the SNN search's.
    #[arg(long, default_value_t = 60)]
    epochs: usize,
    /// --search: a trial stops after this many epochs without a better validation score; as the
    /// SNN search's.
    #[arg(long, default_value_t = 15)]
    patience: usize,
    /// --search: the whole time (trials and final models), in minutes; a trial starts only while
    /// it and the final models are expected to fit.
    #[arg(long)]
    budget_min: Option<f64>,
    /// Score the test split (by default it is not looked at).
    #[arg(long)]
    eval_test: bool,
    /// Write the table (`baselines.md`) and everything measured (`baselines.json`) here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Replace the files in --out.
    #[arg(long)]
    force: bool,
    /// JSON instead of a Markdown table.
    #[arg(long)]
    json: bool,
    /// No per-epoch progress.
    #[arg(long)]
    quiet: bool,
}

/// Prints a line to standard error per trial, skipped trial and final model of the networks' search.
struct TrialPrinter;

impl NetworkObserver for TrialPrinter {
    fn trial(&mut self, kind: TemporalKind, t: &NetworkTrial) {
        eprintln!(
            "{}: trial {}: validation {:.1}% (best epoch {} of {}), {:.1} min",
            kind.name(),
            t.config.describe(),
            100.0 * t.val_accuracy,
            t.best_epoch,
            t.epochs_run,
            t.seconds / 60.0
        );
    }

    fn skipped(&mut self, kind: TemporalKind, c: &TemporalConfig) {
        eprintln!("{}: trial {} skipped: it would not fit the budget", kind.name(), c.describe());
    }

    fn final_model(&mut self, kind: TemporalKind, f: &NetworkFinal) {
        eprintln!(
            "{}: final model, seed {}: train {:.1}%{}, {:.1} min",
            kind.name(),
            f.seed,
            100.0 * f.train_accuracy,
            f.test_accuracy.map_or(String::new(), |a| format!(", test {:.1}%", 100.0 * a)),
            f.seconds / 60.0
        );
    }
}

pub fn run(a: Args) -> Result<()> {
    if let Some(m) = a.budget_min
        && !(m.is_finite() && m >= 0.0)
    {
        bail!("--budget-min: expected a number of minutes, 0 or more, got {m}");
    }
    // refuse to replace the results before the work, not after it
    if let Some(dir) = a.out.as_ref().filter(|_| !a.force)
        && let Some(p) = ["baselines.md", "baselines.json"].map(|f| dir.join(f)).into_iter().find(|p| p.exists())
    {
        bail!("{}: exists; pass --force to replace it", p.display());
    }
    let dataset = Dataset::load(&a.data, a.period_us)?;
    let profile = DataProfile::of(&dataset)?;
    // the events as the derived SNN recipe encodes them (its step and sigma-delta threshold)
    let data = TactileData::encode(&dataset, &derived_recipe(&profile))?;
    let eval_test = if a.eval_test { EvalTest::Yes } else { EvalTest::No };
    let baselines = experiments::train::baselines::baselines(&data, a.val_fraction, a.val_seed, eval_test)?;
    let mut networks = Vec::new();
    if a.search {
        let kinds = a.networks.iter().map(|n| match n {
            Network::Gru => TemporalKind::Gru,
            Network::Lstm => TemporalKind::Lstm,
            Network::Tcn => TemporalKind::Tcn,
        });
        let s = NetworkSearch {
            kinds: kinds.collect(),
            epochs: a.epochs,
            patience: a.patience,
            seeds: a.seeds,
            budget: a.budget_min.map(|m| std::time::Duration::from_secs_f64(60.0 * m)),
            ..NetworkSearch::default()
        };
        let (observer, mut epochs) = (&mut TrialPrinter, Epochs::new(a.quiet));
        networks = experiments::train::networks::search(
            &data,
            a.val_fraction,
            a.val_seed,
            &s,
            eval_test,
            observer,
            &mut epochs,
        )?;
    }
    let table = BaselinesTable { profile, baselines, networks };
    if let Some(dir) = &a.out {
        let flags = [(a.search, " --search"), (a.eval_test, " --eval-test")];
        let flags: String = flags.iter().filter(|(on, _)| *on).map(|(_, f)| *f).collect();
        let command = format!("braille baselines --data {}{flags}", a.data.display());
        let validation = format!(
            "a stratified hold-out of {:.0}% of the training split (seed {}), or the folder's own validation split",
            100.0 * a.val_fraction,
            a.val_seed
        );
        table.write(dir, &command, &validation, eval_test, a.force)?;
        eprintln!("wrote {} and baselines.json", dir.join("baselines.md").display());
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&table)?);
    } else {
        println!("{}", table.markdown());
    }
    Ok(())
}
