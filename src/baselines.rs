//! `braille baselines`: the non-spiking floors of a tactile dataset folder, on the SNN search's
//! validation hold-out (`experiments::train::baselines`); with `--search`, the conventional
//! networks chosen by the same protocol (`experiments::train::networks`) in the same table.

use crate::common::Epochs;
use anyhow::{Context, Result, bail};
use encoders::dataset::Dataset;
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
    /// --search: the networks, their trials taken in turn in this order (the cheapest first, so
    /// that a budget cuts the dearest). whole time (trials and final models), in minutes; a trial starts
    /// only while it and the final models are expected to fit.
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
    if let Some(dir) = &a.out
        && !a.force
    {
        for f in ["baselines.md", "baselines.json"] {
            let p = dir.join(f);
            if p.exists() {
                bail!("{}: exists; pass --force to replace it", p.display());
            }
        }
    }
    let dataset = Dataset::load(&a.data, a.period_us)?;
    let profile = DataProfile::of(&dataset)?;
    // the events as the derived SNN recipe encodes them (its step and sigma-delta threshold)
    let data = TactileData::encode(&dataset, &derived_recipe(&profile))?;
    let eval_test = if a.eval_test { EvalTest::Yes } else { EvalTest::No };
    let rows = experiments::train::baselines::baselines(&data, a.val_fraction, a.val_seed, eval_test)?;
    let networks = if a.search {
        let s = NetworkSearch {
            kinds: a
                .networks
                .iter()
                .map(|n| match n {
                    Network::Gru => TemporalKind::Gru,
                    Network::Lstm => TemporalKind::Lstm,
                    Network::Tcn => TemporalKind::Tcn,
                })
                .collect(),
            epochs: a.epochs,
            patience: a.patience,
            seeds: a.seeds,
            budget: a.budget_min.map(|m| std::time::Duration::from_secs_f64(60.0 * m)),
            ..NetworkSearch::default()
        };
        experiments::train::networks::search(
            &data,
            a.val_fraction,
            a.val_seed,
            &s,
            eval_test,
            &mut TrialPrinter,
            &mut Epochs::new(a.quiet),
        )?
    } else {
        Vec::new()
    };
    let json = serde_json::json!({ "profile": profile, "baselines": rows, "networks": networks });
    let mut markdown = experiments::train::baselines::markdown(&rows, &networks);
    if !networks.is_empty() {
        markdown += &format!("\nThe networks' trials:\n\n{}", experiments::train::networks::trials_markdown(&networks));
    }
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create it", dir.display()))?;
        let header = format!(
            "# Baselines on `{}`\n\nGenerated by `braille baselines --data {}{}{}`. Validation: a stratified hold-out of {:.0}% of the training split (seed {}), or the folder's own validation split; the test split {}.\n\n",
            profile.data,
            a.data.display(),
            if a.search { " --search" } else { "" },
            if a.eval_test { " --eval-test" } else { "" },
            100.0 * a.val_fraction,
            a.val_seed,
            if a.eval_test { "scored once per final model, after every choice" } else { "not looked at" }
        );
        let md = dir.join("baselines.md");
        std::fs::write(&md, header + &markdown).with_context(|| format!("{}: cannot write it", md.display()))?;
        experiments::write_json(&dir.join("baselines.json"), &json, a.force)?;
        eprintln!("wrote {} and baselines.json", md.display());
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        println!("{markdown}");
    }
    Ok(())
}
