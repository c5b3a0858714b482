//! The SNN against conventional networks on tactile datasets (`braille tactile-report`): per
//! dataset folder, the SNN search's final models (one per seed, run by the event-driven engine on
//! the test split) beside the GRU, LSTM and temporal CNN and the linear floors of `braille
//! baselines --search --eval-test` (its `baselines.json`), every one chosen on the same
//! validation hold-out, with seed means and spreads, size, work per sample and energy estimates.

use crate::error::{Error, Result};
use crate::eval::tactile::{SplitChoice, eval_model, eval_split};
use serde::{Deserialize, Serialize};
use snn::energy::{CMOS45_ADD, CMOS45_MAC, LOIHI_SYNOP};
use snn::engine::Mode;
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// One dataset to report: its name, folder, the SNN searches that may stand for it and the
/// baselines' folder.
#[derive(Debug, Clone)]
pub struct TactileSource {
    pub name: String,
    pub data: PathBuf,
    /// The SNN searches, the one listed first winning ties; the better by validation score stands
    /// for the dataset, the others' test split is not read.
    pub snn: Vec<SnnSearch>,
    pub baselines: PathBuf,
}

impl TactileSource {
    /// A dataset named on the command line as `NAME=FOLDER`: its SNN searches under the fixed
    /// rule ([`SnnSearch::under_rule`]) in `search` and `logs`, its networks' and floors' results
    /// `NAME/` under `baselines`; the folder must exist.
    pub fn parse(arg: &str, search: &Path, logs: &Path, baselines: &Path) -> Result<TactileSource> {
        let Some((name, folder)) = arg.split_once('=') else {
            return Err(Error::Options(format!("--dataset {arg}: expected NAME=FOLDER")));
        };
        let data = PathBuf::from(folder);
        if !data.is_dir() {
            let hint = if name == "sim-taxels" {
                " (generate it: bash scripts/search_taxels.sh, or braille sim dataset --out DIR)"
            } else {
                ""
            };
            return Err(Error::Data { path: data, what: format!("no dataset folder here{hint}") });
        }
        let snn = SnnSearch::under_rule(name, search, logs);
        Ok(TactileSource { name: name.to_string(), data, snn, baselines: baselines.join(name) })
    }
}

/// One SNN search: its final models (`RUN.safetensors`, `RUN.seed2.safetensors`, ...) and the
/// folder of its trial log (`trials-*.jsonl`), whose winner's score (the mean validation accuracy
/// over the last epochs and the trial's seeds) decides between the searches of a dataset.
#[derive(Debug, Clone)]
pub struct SnnSearch {
    /// What sets this search apart from the others of the dataset ("truncated gradients").
    pub label: String,
    pub models: PathBuf,
    pub trials: PathBuf,
}

impl SnnSearch {
    /// The searches that may stand for `dataset` under the rule #51's decisions fixed
    /// (docs/training.md): the derived space searched with truncated gradients and with exact
    /// ones, their models under `models` and their trial logs under `logs`. Since the tenth
    /// decision (2026-12-01) the space has the step at 1 and 2 times the derived one: raw1350's
    /// and the taxels' searches with it are one `--both-gradients` run, `NAME-stepscale` (its
    /// logs in `truncated/` and `exact/`, the final models of the better one only); th10's
    /// 12-trial searches never reach the step's neighbour, so its searches without the step
    /// (the run [`search_run`](crate::reports::icub::search_run) names, and `NAME-exact`) are
    /// its searches with it, trial for trial.
    pub fn under_rule(dataset: &str, models: &Path, logs: &Path) -> Vec<SnnSearch> {
        let search = |label: &str, run: &str, trials: PathBuf| SnnSearch {
            label: label.into(),
            models: models.join(format!("{run}.safetensors")),
            trials,
        };
        match dataset {
            "raw1350" | "sim-taxels" => {
                let run = format!("{dataset}-stepscale");
                let dir = logs.join(&run);
                vec![
                    search("truncated gradients, step searched", &run, dir.join("truncated")),
                    search("exact gradients, step searched", &run, dir.join("exact")),
                ]
            }
            _ => {
                let (truncated, exact) = (crate::reports::icub::search_run(dataset), format!("{dataset}-exact"));
                vec![
                    search("truncated gradients", &truncated, logs.join(&truncated)),
                    search("exact gradients", &exact, logs.join(&exact)),
                ]
            }
        }
    }
}

/// A search of [`SnnSearch`] whose final models are there: the models, one per seed, and its
/// winning trial's validation score.
#[derive(Debug, Clone)]
pub struct FoundSearch<'a> {
    pub search: &'a SnnSearch,
    pub models: Vec<PathBuf>,
    pub validation_score: f64,
}

/// The searches of `searches` whose final models are there, and which of them stands (the
/// highest validation score, the first of equals); none when no search has its models.
pub fn found_searches(searches: &[SnnSearch]) -> Result<(Vec<FoundSearch<'_>>, Option<usize>)> {
    let mut found = Vec::new();
    for s in searches {
        let models: Vec<PathBuf> =
            (1..).map(|seed| crate::train::search::seed_path(&s.models, seed)).take_while(|p| p.is_file()).collect();
        if models.is_empty() {
            continue;
        }
        let trials = crate::train::search::read_logs(&s.trials)?;
        let Some(winner) = crate::train::search::winner(&trials) else {
            return Err(Error::Data { path: s.trials.clone(), what: "no trial logged: no validation score".into() });
        };
        // a `--both-gradients` run trains the final models of its better search only, and both
        // of its searches name them: they are this search's only if they were trained with its
        // gradients
        let model = pipeline::models::load_snn(&models[0])?;
        let cutoff = model.provenance["recipe"]["gradient_cutoff"].as_f64();
        if cutoff.is_some_and(|c| c as f32 != winner.recipe.gradient_cutoff) {
            continue;
        }
        found.push(FoundSearch { search: s, models, validation_score: winner.score });
    }
    let scores: Vec<f64> = found.iter().map(|f| f.validation_score).collect();
    let chosen = crate::train::search::best_score(&scores);
    Ok((found, chosen))
}

/// One model's line.
#[derive(Debug, Clone, Serialize)]
pub struct ModelLine {
    pub model: String,
    /// What validation chose.
    pub choice: String,
    /// Test accuracy per seed (one for the deterministic floors).
    pub test_accuracies: Vec<f64>,
    pub mean: f64,
    /// Sample standard deviation over seeds (NaN for one).
    pub sd: f64,
    pub parameters: usize,
    /// Synaptic operations (SNN) or multiply-accumulates (the others) per sample.
    pub ops_per_sample: f64,
    pub spiking: bool,
    /// An SNN search's winning validation score (the others: none).
    pub validation_score: Option<f64>,
    /// Seed ensembles of the standing SNN search's recipe, beside the single networks: each
    /// "seed" a merged ensemble of three ([`ENSEMBLE_MEMBERS`]).
    pub ensemble: bool,
}

/// The folder, beside an SNN search's final models, of more final models of its recipe (seeds 4
/// and on, `scripts/ensembles.sh`): the standing search's seeds 1-3, 4-6, 7-9 ... make one
/// ensemble each (`braille ensemble`), which the report scores beside the single networks.
pub const ENSEMBLE_MEMBERS: &str = "ensemble-members";

impl ModelLine {
    /// Energy per sample in microjoules: SynOps at a 45 nm float add and on Loihi; MACs at a 45
    /// nm float multiply-accumulate.
    pub fn energy_uj(&self) -> (f64, Option<f64>) {
        if self.spiking {
            (CMOS45_ADD.nanojoules(self.ops_per_sample) / 1e3, Some(LOIHI_SYNOP.nanojoules(self.ops_per_sample) / 1e3))
        } else {
            (CMOS45_MAC.nanojoules(self.ops_per_sample) / 1e3, None)
        }
    }
}

/// A dataset's lines, the SNN first.
#[derive(Debug, Clone, Serialize)]
pub struct TactileRow {
    pub dataset: String,
    pub lines: Vec<ModelLine>,
}

impl TactileRow {
    fn best(&self, pick: impl Fn(&ModelLine) -> bool) -> Option<&ModelLine> {
        self.lines.iter().filter(|l| pick(l)).max_by(|a, b| a.mean.total_cmp(&b.mean))
    }

    /// The SNN's mean (a single network per seed) minus the best conventional network's, and
    /// minus the best linear floor's, in points.
    pub fn gaps(&self) -> (Option<f64>, Option<f64>) {
        self.gaps_of(|l| !l.ensemble)
    }

    /// As [`Self::gaps`], for the seed ensembles' line where there is one.
    pub fn ensemble_gaps(&self) -> (Option<f64>, Option<f64>) {
        self.gaps_of(|l| l.ensemble)
    }

    fn gaps_of(&self, pick: impl Fn(&ModelLine) -> bool) -> (Option<f64>, Option<f64>) {
        let Some(snn) = self.lines.iter().find(|l| l.spiking && !l.test_accuracies.is_empty() && pick(l)) else {
            return (None, None);
        };
        let net = self.best(|l| !l.spiking && !is_linear(l));
        let floor = self.best(is_linear);
        (net.map(|n| 100.0 * (snn.mean - n.mean)), floor.map(|f| 100.0 * (snn.mean - f.mean)))
    }
}

fn is_linear(l: &ModelLine) -> bool {
    l.model.contains("regression")
}

/// What `braille baselines --out` wrote, as far as this report reads it.
#[derive(Deserialize)]
struct BaselinesFile {
    baselines: Vec<Floor>,
    #[serde(default)]
    networks: Vec<Net>,
}

#[derive(Deserialize)]
struct Floor {
    model: String,
    choice: String,
    parameters: usize,
    macs_per_sample: u64,
    test_accuracy: Option<f64>,
}

#[derive(Deserialize)]
struct Net {
    kind: learn::temporal::TemporalKind,
    trials: Vec<NetTrial>,
    winner: Option<usize>,
    finals: Vec<NetFinal>,
    parameters: usize,
    macs_per_sample: u64,
}

#[derive(Deserialize)]
struct NetTrial {
    config: learn::temporal::TemporalConfig,
}

#[derive(Deserialize)]
struct NetFinal {
    test_accuracy: Option<f64>,
}

fn line(model: String, choice: String, accuracies: Vec<f64>, parameters: usize, ops: f64, spiking: bool) -> ModelLine {
    let (mean, sd) = crate::eval::scoring::mean_sd(&accuracies).unwrap_or((f64::NAN, f64::NAN));
    ModelLine {
        model,
        choice,
        test_accuracies: accuracies,
        mean,
        sd,
        parameters,
        ops_per_sample: ops,
        spiking,
        validation_score: None,
        ensemble: false,
    }
}

/// The report's row of `source`: the SNN searches (the test split read only by the final models
/// of the one with the best validation score), then the networks and the floors.
pub fn tactile_row(source: &TactileSource) -> Result<TactileRow> {
    let (found, chosen) = found_searches(&source.snn)?;
    let Some(chosen) = chosen else {
        let path = source.snn.first().map_or_else(|| source.data.clone(), |s| s.models.clone());
        return Err(Error::Model {
            path,
            what: "no SNN search model here (`braille train --data DIR --search --seeds 3 --out FILE`)".into(),
        });
    };
    let mut lines: Vec<ModelLine> = Vec::new();
    for (i, f) in found.iter().enumerate() {
        let mut l = snn_line(source, f.search, &f.models, i == chosen)?;
        l.validation_score = Some(f.validation_score);
        lines.push(l);
    }
    let standing = &found[chosen];
    if let Some(l) = ensemble_line(source, standing, lines[chosen].parameters)? {
        lines.insert(found.len(), l);
    }
    let path = source.baselines.join("baselines.json");
    let text = std::fs::read_to_string(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
    let b: BaselinesFile = serde_json::from_str(&text)
        .map_err(|e| Error::Data { path: path.clone(), what: format!("not a `braille baselines --out` file: {e}") })?;
    for n in &b.networks {
        let Some(w) = n.winner else { continue };
        let acc: Vec<f64> = n.finals.iter().filter_map(|f| f.test_accuracy).collect();
        if acc.is_empty() {
            return Err(Error::Data { path: path.clone(), what: "run without --eval-test: no test accuracies".into() });
        }
        lines.push(line(
            format!("{} ({} seeds)", n.kind.name(), acc.len()),
            n.trials[w].config.describe(),
            acc,
            n.parameters,
            n.macs_per_sample as f64,
            false,
        ));
    }
    for f in &b.baselines {
        let Some(a) = f.test_accuracy else {
            return Err(Error::Data { path: path.clone(), what: "run without --eval-test: no test accuracies".into() });
        };
        lines.push(line(f.model.clone(), f.choice.clone(), vec![a], f.parameters, f.macs_per_sample as f64, false));
    }
    Ok(TactileRow { dataset: source.name.clone(), lines })
}

/// The line of one SNN search: with `read_test`, its final models on the test split (seed mean,
/// SynOps per sample); without, its size alone.
fn snn_line(source: &TactileSource, search: &SnnSearch, models: &[PathBuf], read_test: bool) -> Result<ModelLine> {
    let (mut accuracies, mut synops) = (Vec::new(), f64::NAN);
    if read_test {
        synops = 0.0;
        for m in models {
            let (e, _) = eval_split(m, &source.data, SplitChoice::Test, Mode::Stepped)?;
            accuracies.push(e.accuracy);
            synops += e.synops_per_sample / models.len() as f64;
        }
    }
    let first = pipeline::models::load_snn(&models[0])?;
    let spec = &first.config.network;
    let parameters = spec
        .shapes()?
        .iter()
        .zip(&spec.layers)
        .map(|(s, l)| {
            let n = |v: &[usize]| if v.is_empty() { 0 } else { v.iter().product::<usize>() };
            n(&s.weight)
                + if l.bias { n(&s.bias) } else { 0 }
                + if l.recurrent { n(&s.recurrent) } else { 0 }
                + if l.recurrent_bias { n(&s.recurrent_bias) } else { 0 }
        })
        .sum();
    let hidden: Vec<String> = spec.layers[..spec.layers.len() - 1]
        .iter()
        .filter_map(|l| match l.op {
            snn::spec::OpSpec::Dense { n_out } => Some(format!(
                "{n_out} {}{}",
                l.neurons.map_or(String::new(), |p| format!("{:?}", p.kind)),
                if l.recurrent { " (recurrent)" } else { "" }
            )),
            _ => None,
        })
        .collect();
    Ok(line(
        format!("SNN, {} ({} seeds)", search.label, models.len()),
        format!("the search's winner: {}, dt {} ms", hidden.join(", "), first.config.dt_us as f64 / 1e3),
        accuracies,
        parameters,
        synops,
        true,
    ))
}

/// The seed ensembles of the standing search `f` (its final models of seeds 1-3, then three at a
/// time from [`ENSEMBLE_MEMBERS`]), each merged and scored on the test split; none without
/// members there.
fn ensemble_line(source: &TactileSource, f: &FoundSearch<'_>, member_parameters: usize) -> Result<Option<ModelLine>> {
    const SIZE: usize = 3;
    let (Some(dir), Some(name)) = (f.search.models.parent(), f.search.models.file_name()) else {
        return Ok(None);
    };
    let base = dir.join(ENSEMBLE_MEMBERS).join(name);
    let more: Vec<PathBuf> = (SIZE as u64 + 1..)
        .map(|seed| crate::train::search::seed_path(&base, seed))
        .take_while(|p| p.is_file())
        .collect();
    if more.is_empty() || f.models.len() != SIZE {
        return Ok(None);
    }
    let all: Vec<PathBuf> = f.models.iter().cloned().chain(more).collect();
    let (mut accuracies, mut synops, mut names) = (Vec::new(), 0.0, Vec::new());
    let groups = all.len() / SIZE;
    for (g, members) in all.chunks_exact(SIZE).enumerate() {
        let seeds = format!("{}-{}", g * SIZE + 1, (g + 1) * SIZE);
        let model = crate::train::fit::ensemble(members)?;
        let label = base.with_file_name(format!("ensemble of seeds {seeds} of {}", name.to_string_lossy()));
        let (e, _) = eval_model(&model, &label, &source.data, SplitChoice::Test, Mode::Stepped)?;
        accuracies.push(e.accuracy);
        synops += e.synops_per_sample / groups as f64;
        names.push(seeds);
    }
    let mut l = line(
        format!("SNN, ensembles of {SIZE}, {} ({groups} ensembles: seeds {})", f.search.label, names.join(" / ")),
        format!(
            "beside, chosen by nothing: the line above's recipe, {SIZE} seeds merged (`braille ensemble`), {SIZE} networks' work"
        ),
        accuracies,
        SIZE * member_parameters,
        synops,
        true,
    );
    l.ensemble = true;
    Ok(Some(l))
}

/// The rows of `sources`, written to `out` as `tactile.md` and `tactile.json`; the Markdown.
pub fn write_report(sources: &[TactileSource], out: &Path) -> Result<String> {
    let rows = sources.iter().map(tactile_row).collect::<Result<Vec<_>>>()?;
    let md = markdown(&rows)?;
    std::fs::create_dir_all(out).map_err(|source| Error::Io { path: out.to_path_buf(), source })?;
    let path = out.join("tactile.md");
    std::fs::write(&path, &md).map_err(|source| Error::Io { path, source })?;
    crate::write_json(&out.join("tactile.json"), &rows, true)?;
    Ok(md)
}

/// The rows as Markdown.
pub fn markdown(rows: &[TactileRow]) -> Result<String> {
    let mut md = String::new();
    writeln!(md, "# The SNN against conventional networks on tactile data\n")?;
    writeln!(
        md,
        "Regenerate: `braille tactile-report` (the SNN searches' models from `scripts/lodo_step_scale.sh` for raw1350 and the taxel set, `scripts/search_icub.sh --defaults` and `scripts/lodo_exact.sh --search` for th10; the networks and floors from `scripts/baselines.sh`, which regenerates the SIMULATED taxel set in `target/sim-taxels`). Every model was chosen on the same stratified 20% validation hold-out of the training split (seed 1), and each final model's test split scored once it was trained; but all three datasets are **development folds**: earlier rounds' test figures decided whether the SNN's search design went on (ten design rounds; the networks' search had one), so no figure here is held out (raw1350 96.54% before the test-informed rounds; th10 73.21% held out of the choice of the search's defaults: docs/training.md). The SNN is the better by validation score (the winning trial's mean over its last 5 epochs and 3 seeds) of the dataset's two searches, with truncated and with exact gradients, the step searched at 1 and 2 times the derived one (the rule #51's leave-one-dataset-out decisions fixed, docs/training.md; th10's 12 trials never reach the step's neighbour, so its searches are the same with the step as without); the other's final models are not trained, or do not read the test split. The SNN and the networks: mean of the final models over seeds 1-3 (sample s.d.), each seed's score beside it; the linear floors are deterministic (one fit). Beside the SNN, where `scripts/ensembles.sh` trained seeds 4-9 of its recipe: its seed ensembles of three (seeds 1-3, 4-6 and 7-9 merged by `braille ensemble`), each scored once, a mean over the three ensembles; they are chosen by nothing, their work is three networks', and they are not the SNN's figure (the rule, docs/training.md, keeps them beside the recipe). The SNN runs on the event-driven engine. Work per sample: SynOps for the SNN, multiply-accumulates for the others (the networks' gates and the floors' binning not counted). Energy: SynOps at a 45 nm 32-bit float add ({} pJ) and on Loihi ({} pJ), MACs at a 45 nm 32-bit float multiply-accumulate ({} pJ) ({}; {}); arithmetic only.\n",
        CMOS45_ADD.pj_per_op, LOIHI_SYNOP.pj_per_op, CMOS45_MAC.pj_per_op, CMOS45_MAC.source, LOIHI_SYNOP.source
    )?;
    writeln!(
        md,
        "| data | SNN minus the best network | SNN minus the best linear floor | beside: SNN ensembles of 3 minus the best network |\n| --- | --- | --- | --- |"
    )?;
    for r in rows {
        let (net, floor) = r.gaps();
        let pts = |g: Option<f64>| g.map_or("n/a".into(), |g| format!("{g:+.1} points"));
        writeln!(md, "| {} | {} | {} | {} |", r.dataset, pts(net), pts(floor), pts(r.ensemble_gaps().0))?;
    }
    for r in rows {
        writeln!(md, "\n## {}\n", r.dataset)?;
        writeln!(
            md,
            "| model | chosen on validation | **test, mean (s.d.)** | per seed | parameters | work / sample | energy / sample: 45 nm | Loihi |\n| --- | --- | --- | --- | --- | --- | --- | --- |"
        )?;
        for l in &r.lines {
            let mean = if l.test_accuracies.is_empty() {
                "not scored here (lower on validation)".to_string()
            } else if l.sd.is_nan() {
                format!("{:.1}%", 100.0 * l.mean)
            } else {
                format!("**{:.1}%** ({:.1})", 100.0 * l.mean, 100.0 * l.sd)
            };
            let per = if l.test_accuracies.len() > 1 {
                l.test_accuracies.iter().map(|a| format!("{:.1}", 100.0 * a)).collect::<Vec<_>>().join(" / ")
            } else {
                String::new()
            };
            let choice = match l.validation_score {
                Some(v) => format!("{}; validation score {:.2}%", l.choice, 100.0 * v),
                None => l.choice.clone(),
            };
            let (work, e45, loihi) = if l.ops_per_sample.is_nan() {
                (String::new(), String::new(), String::new())
            } else {
                let (e45, loihi) = l.energy_uj();
                (
                    format!("{:.0} {}", l.ops_per_sample, if l.spiking { "SynOps" } else { "MACs" }),
                    format!("{e45:.3} uJ"),
                    loihi.map_or(String::new(), |e| format!("{e:.3} uJ")),
                )
            };
            writeln!(md, "| {} | {choice} | {mean} | {per} | {} | {work} | {e45} | {loihi} |", l.model, l.parameters)?;
        }
    }
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_compare_the_snn_with_the_best_network_and_the_best_floor() {
        let l = |m: &str, acc: f64, spiking| line(m.into(), String::new(), vec![acc], 1, 1.0, spiking);
        let row = TactileRow {
            dataset: "d".into(),
            lines: vec![
                // an SNN search whose test split was not read stands for nothing
                line("SNN, lower on validation".into(), String::new(), Vec::new(), 1, f64::NAN, true),
                l("SNN", 0.80, true),
                line("SNN, ensembles".into(), String::new(), vec![0.9, 0.88], 3, 3.0, true),
                l("GRU", 0.85, false),
                l("temporal CNN", 0.75, false),
                l("ridge regression", 0.60, false),
                l("logistic regression", 0.70, false),
            ],
        };
        let mut row = row;
        row.lines[2].ensemble = true;
        let (net, floor) = row.gaps();
        let (ens, _) = row.ensemble_gaps();
        assert!((ens.unwrap() - 4.0).abs() < 1e-9, "the ensembles' gap apart: {ens:?}");
        assert_eq!(crate::train::search::best_score(&[0.9, 0.95, 0.95, 0.8]), Some(1), "the first of equals");
        assert_eq!(crate::train::search::best_score(&[]), None);
        assert!((net.unwrap() + 5.0).abs() < 1e-9 && (floor.unwrap() - 10.0).abs() < 1e-9);
        // SynOps cost an add, MACs a multiply-accumulate
        assert!(l("SNN", 0.8, true).energy_uj().1.is_some() && l("GRU", 0.8, false).energy_uj().1.is_none());
    }
}
