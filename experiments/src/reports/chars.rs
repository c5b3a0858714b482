//! The paper's Table I (Raw / Norm / Aug / NormAug) and its depth figure on SIMULATED scans of
//! the RAB board at 8 mm/s, with the SNN beside the ResNet on the same windows, confusion matrices
//! and energy estimates.

use crate::Progress;
use crate::error::{Error, Result};
use crate::eval::chars::{CharModel, Score};
use corpus::windows::{CharSetSpec, Task, Windows, build, build_many};
use corpus::world::World;
use pipeline::input::CharInput;
use serde::Serialize;
use sim::BoardKind;
use snn::model_file::Arch;
use std::fmt::Write as _;
use std::path::Path;

/// The paper's test depths, in mm.
pub const DEPTHS_MM: [f64; 7] = [0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5];

/// One model of the table.
#[derive(Debug, Clone, Serialize)]
pub struct Entry {
    pub key: &'static str,
    pub name: String,
    pub arch: Arch,
    pub model: String,
    /// ResNet: multiply-accumulates per window.
    pub macs: Option<u64>,
    /// One score per depth, in the order of `depths_mm`: over the windows of the scans whose
    /// character count the labeler found (the paper's protocol, conditional).
    pub scores: Vec<Score>,
    /// Per depth, over every printed character: those of scans the labeler miscounted count as
    /// errors (the headline).
    pub accuracy_all: Vec<f64>,
    /// The same on the EV rows, per speed of `ev_speeds_mm_s`.
    pub ev_accuracy_all: Vec<f64>,
}

/// Table I, the depth curve and the word rows' data.
#[derive(Debug, Clone, Serialize)]
pub struct CharsReport {
    pub data: &'static str,
    pub board: &'static str,
    pub speed_mm_s: f64,
    pub trials: u64,
    pub seed: u64,
    pub depths_mm: Vec<f64>,
    /// Per depth: windows scored, scans, scans the labeler miscounted (no windows scored), and
    /// characters printed on all scans.
    pub windows: Vec<usize>,
    pub scans: Vec<usize>,
    pub skipped_scans: Vec<usize>,
    pub printed: Vec<usize>,
    pub entries: Vec<Entry>,
    /// Word rows: the EV board at 1.5 mm, per speed in `ev_speeds_mm_s`, one score per entry.
    pub ev_speeds_mm_s: Vec<f64>,
    pub ev: Vec<Vec<Score>>,
    pub ev_skipped_scans: Vec<usize>,
    pub ev_printed: Vec<usize>,
    /// The simulated world of the test scans.
    pub world: World,
}

impl CharsReport {
    /// The index of the 1.5 mm depth (Table I's), else the deepest.
    pub fn table_depth(&self) -> usize {
        self.depths_mm.iter().position(|&d| d == 1.5).unwrap_or(self.depths_mm.len() - 1)
    }
}

/// Every character model under `models` (those that exist of the known names) on the same
/// SIMULATED RAB scans at each depth of `depths` (the paper's when empty), and on EV word rows.
pub fn chars_report(
    models: &Path,
    depths: &[f64],
    trials: u64,
    seed: u64,
    world: &World,
    progress: &dyn Progress,
) -> Result<CharsReport> {
    let depths = if depths.is_empty() { DEPTHS_MM.to_vec() } else { depths.to_vec() };
    // every Table I classifier the registry of shipped models names (the words models last: they
    // go beyond the paper's training protocol)
    let known = pipeline::shipped::TABLE_I;
    let dir = models;
    let mut models = Vec::new();
    for (key, name, file) in known {
        let p = dir.join(format!("{file}.safetensors"));
        if p.exists() {
            models.push((key, name.to_string(), CharModel::load(&p)?, p));
        }
    }
    if models.is_empty() {
        return Err(Error::Model {
            path: dir.to_path_buf(),
            what: "no character models (run scripts/table1.sh)".into(),
        });
    }
    let mut entries: Vec<Entry> = models
        .iter()
        .map(|(key, name, m, p)| Entry {
            key,
            name: name.clone(),
            arch: m.arch(),
            model: p.display().to_string(),
            macs: m.macs(),
            scores: vec![],
            accuracy_all: vec![],
            ev_accuracy_all: vec![],
        })
        .collect();
    let chars: Vec<&CharModel> = models.iter().map(|m| &m.2).collect();
    let (mut windows, mut scans, mut skipped_scans, mut printed) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for &depth in &depths {
        let spec = CharSetSpec {
            boards: vec![BoardKind::Rab],
            speed_mm_s: 8.0,
            depth_mm: depth,
            trials,
            seed,
            task: Task::Chars,
            jitter_ms: 0.0,
            world: world.clone(),
            blank_cells: false,
            sweep: None,
        };
        let (scores, w) = score_all(&spec, &chars, progress)?;
        for (e, s) in entries.iter_mut().zip(scores) {
            let all = w.accuracy_all(right(&s));
            progress.note(&format!(
                "SIMULATED RAB {depth} mm: {}: {:.2}% of {} printed ({:.2}% of {} windows found)",
                e.name,
                100.0 * all,
                w.printed,
                100.0 * s.accuracy,
                s.n
            ));
            e.accuracy_all.push(all);
            e.scores.push(s);
        }
        windows.push(w.sets.first().map_or(0, |s| s.len()));
        scans.push(w.scans);
        skipped_scans.push(w.skipped_scans);
        printed.push(w.printed);
    }
    // Word rows: letters at the cell spacing of words, with neighbours in view.
    let ev_speeds = vec![8.0, 16.0];
    let (mut ev, mut ev_skipped_scans, mut ev_printed) = (Vec::new(), Vec::new(), Vec::new());
    for &speed in &ev_speeds {
        let spec = CharSetSpec {
            boards: vec![BoardKind::Ev],
            speed_mm_s: speed,
            depth_mm: 1.5,
            trials,
            seed,
            task: Task::Chars,
            jitter_ms: 0.0,
            world: world.clone(),
            blank_cells: false,
            sweep: None,
        };
        let (row, w) = score_all(&spec, &chars, progress)?;
        for (e, s) in entries.iter_mut().zip(&row) {
            e.ev_accuracy_all.push(w.accuracy_all(right(s)));
            progress.note(&format!("SIMULATED EV {speed} mm/s: {}: {:.2}% of {}", e.name, 100.0 * s.accuracy, s.n));
        }
        ev.push(row);
        ev_skipped_scans.push(w.skipped_scans);
        ev_printed.push(w.printed);
    }
    Ok(CharsReport {
        data: "simulated (virtual Evetac)",
        board: "RAB",
        speed_mm_s: 8.0,
        trials,
        seed,
        depths_mm: depths,
        windows,
        scans,
        skipped_scans,
        printed,
        entries,
        ev_speeds_mm_s: ev_speeds,
        ev,
        ev_skipped_scans,
        ev_printed,
        world: world.clone(),
    })
}

/// The report as Markdown.
pub fn markdown(r: &CharsReport) -> Result<String> {
    let mut md = String::new();
    let at = r.depths_mm.iter().position(|&d| d == 1.5).unwrap_or(r.depths_mm.len() - 1);
    writeln!(md, "# Character recognition on SIMULATED scans (virtual Evetac)\n")?;
    writeln!(
        md,
        "Regenerate: `REALISM={} bash scripts/table1.sh` (trains the four ResNet configurations and the SNN, then runs `braille chars-report`); the `+ words` models come from `REALISM={} bash scripts/words.sh`. Training: SAB and UN boards, 8 mm/s, 1.5 mm (the paper's protocol; the `+ words` models also on word rows, with shifted windows). Test: {} scans per row of the RAB board at 8 mm/s, seed {} ({} characters printed per depth); every model sees the same windows. All data simulated.\n",
        r.world.realism,
        r.world.realism,
        r.trials,
        r.seed,
        r.printed.get(at).copied().unwrap_or(0)
    )?;
    if r.world.realism != sim::Realism::Clean {
        let which = if r.world.sensors == corpus::world::TRAIN_SENSORS {
            "the builds the training scans came from (new scans of RAB, a board no training scan shows): the paper's protocol, which tested with the sensor it trained on"
        } else {
            "which no model was trained on (the paper tested with the sensor it trained on: the same table on the training builds is `chars-report --sensor-builds training`)"
        };
        writeln!(
            md,
            "Simulator preset: `{}`; test scans by sensor builds {:?}, {which} (docs/simulator.md).\n",
            r.world.realism, r.world.sensors
        )?;
    }
    writeln!(md, "## Table I: RAB at {} mm\n", r.depths_mm[at])?;
    writeln!(
        md,
        "The labeler cuts a scan into windows by its activity peaks, told the row's character count for labelling (training data's truth, as in the paper). On {} of {} test scans it found another count; those scans give no windows. **Accuracy over every printed character** ({} characters) counts their characters as errors; the paper's protocol, accuracy over the {} windows found, is **conditional** on the labeler's count and stands beside it.\n",
        r.skipped_scans[at], r.scans[at], r.printed[at], r.windows[at]
    )?;
    writeln!(
        md,
        "| model | **accuracy, every printed character** | accuracy, windows found (the paper's protocol) | macro F1 | loss |"
    )?;
    writeln!(md, "| --- | --- | --- | --- | --- |")?;
    for e in &r.entries {
        let s = &e.scores[at];
        writeln!(
            md,
            "| {} | {:.2}% | {:.2}% | {:.3} | {:.3} |",
            e.name,
            100.0 * e.accuracy_all[at],
            100.0 * s.accuracy,
            s.macro_f1,
            s.loss
        )?;
    }
    writeln!(md, "\nThe paper (real Evetac recordings, its protocol): NormAug 99.54%.\n")?;
    if r.entries.iter().any(|e| e.key == "paper-normaug") {
        writeln!(
            md,
            "`ResNet-34 (paper preset)` is the paper's architecture (ResNet-34 stages, three fully connected layers) on the whole 160x120 pooled frame, trained by the NormAug recipe of the lite models; how long it was trained and its validation curve are in docs/characters.md. The `lite` models are ours (a narrower ResNet on the row band).\n"
        )?;
    }
    writeln!(md, "## Accuracy against depth (RAB, 8 mm/s)\n")?;
    writeln!(
        md,
        "Each cell: accuracy over every printed character, then (in brackets) over the windows the labeler found, the paper's protocol.\n"
    )?;
    write!(md, "| depth (mm) | scans miscounted | windows found / printed |")?;
    for e in &r.entries {
        write!(md, " {} |", e.name)?;
    }
    writeln!(md)?;
    writeln!(md, "|{}", " --- |".repeat(3 + r.entries.len()))?;
    for (i, d) in r.depths_mm.iter().enumerate() {
        write!(md, "| {d} | {} of {} | {} / {} |", r.skipped_scans[i], r.scans[i], r.windows[i], r.printed[i])?;
        for e in &r.entries {
            write!(md, " {:.1}% ({:.1}%) |", 100.0 * e.accuracy_all[i], 100.0 * e.scores[i].accuracy)?;
        }
        writeln!(md)?;
    }
    // targets
    writeln!(md, "\n## Targets\n")?;
    let normaug = r.entries.iter().find(|e| e.key == "normaug");
    if let Some(n) = normaug {
        let a = n.accuracy_all[at];
        writeln!(
            md,
            "- NormAug at 1.5 mm at least 99.5% (every printed character): {:.2}%, {}.",
            100.0 * a,
            met(a >= 0.995)
        )?;
        let from = r.depths_mm.iter().enumerate().filter(|(_, d)| **d >= 0.6 - 1e-9);
        let worst = from.map(|(i, d)| (n.accuracy_all[i], *d)).fold((1.0, 0.0), |w, x| if x.0 < w.0 { x } else { w });
        writeln!(
            md,
            "- NormAug at least 95% at every depth from 0.6 mm: lowest {:.1}% (at {} mm), {}.",
            100.0 * worst.0,
            worst.1,
            met(worst.0 >= 0.95)
        )?;
    }
    // The SNN against the ResNet trained the same way: stepped (the trained network exactly) and
    // async (the same weights in continuous time on the event-driven engine).
    let pairs =
        [("normaug", "snn", "both on the paper's protocol"), ("normaug-words", "snn-words", "both also on words")];
    let find = |key: &str| r.entries.iter().find(|e| e.key == key);
    let mut snns = Vec::new();
    for (resnet, snn, protocol) in pairs {
        let (Some(n), Some(s)) = (find(resnet), find(snn)) else { continue };
        let worst = |acc: &dyn Fn(&Score) -> Option<f64>| {
            n.scores
                .iter()
                .zip(&s.scores)
                .map(|(a, b)| acc(b).map(|b| 100.0 * (a.accuracy - b)))
                .try_fold(f64::NEG_INFINITY, |w, g| g.map(|g| w.max(g)))
        };
        let stepped = worst(&|x| Some(x.accuracy)).unwrap_or(f64::NAN);
        write!(
            md,
            "- {} within 1.5 points of {} ({protocol}) at every depth: largest shortfall {:.2} points stepped, {}",
            s.name,
            n.name,
            stepped,
            met(stepped <= 1.5)
        )?;
        match worst(&|x| x.accuracy_async) {
            Some(a) => writeln!(md, " (in async mode, which training never saw: {:.2} points).", a)?,
            None => writeln!(md, ".")?,
        }
        snns.push(s);
    }
    for s in snns {
        writeln!(md, "\n## {}: stepped and async engine, work per window\n", s.name)?;
        writeln!(md, "| depth (mm) | stepped | async | input events / window | synops / window | spikes / window |")?;
        writeln!(md, "| --- | --- | --- | --- | --- | --- |")?;
        for (i, d) in r.depths_mm.iter().enumerate() {
            let x = &s.scores[i];
            writeln!(
                md,
                "| {d} | {:.1}% | {} | {:.0} | {:.0} | {:.0} |",
                100.0 * x.accuracy,
                x.accuracy_async.map_or("n/a".into(), |a| format!("{:.1}%", 100.0 * a)),
                x.input_events_per_sample.unwrap_or(0.0),
                x.synops_per_sample.unwrap_or(0.0),
                x.spikes_per_sample.unwrap_or(0.0)
            )?;
        }
        writeln!(
            md,
            "\n`stepped` evaluates thresholds at the 10 ms step boundaries and reproduces the trained network spike for spike; `async` runs the same weights in continuous time, firing the moment a membrane crosses threshold (the time-stepped training never saw that)."
        )?;
    }
    writeln!(md, "\n## Letters in words: rows of the EV board (1.5 mm)\n")?;
    writeln!(
        md,
        "Letters at the 6 mm cell spacing of words, so that a window also holds the neighbours' dots; the paper's training boards (SAB, UN) spread their letters over the row. `+ words` models were also trained on 80 rows of random words (TextBlob's frequent words, none of EV's; `--words 80`) and on every window shifted by 40 ms either way (`--jitter-ms 40`, as a streaming reader meets them), beyond the paper's protocol (`scripts/words.sh`).\n"
    )?;
    write!(md, "| model |")?;
    for v in &r.ev_speeds_mm_s {
        write!(md, " EV, {v} mm/s |")?;
    }
    writeln!(md)?;
    writeln!(md, "|{}", " --- |".repeat(1 + r.ev_speeds_mm_s.len()))?;
    for (k, e) in r.entries.iter().enumerate() {
        write!(md, "| {} |", e.name)?;
        for (j, row) in r.ev.iter().enumerate() {
            write!(
                md,
                " {:.1}% of {} printed ({:.1}% of {} found) |",
                100.0 * e.ev_accuracy_all[j],
                r.ev_printed[j],
                100.0 * row[k].accuracy,
                row[k].n
            )?;
        }
        writeln!(md)?;
    }
    energy_section(&mut md, r, at)?;
    writeln!(
        md,
        "\nFigures: `chars_depth.png` (accuracy against depth), `chars_confusion_normaug.png`, `chars_confusion_snn.png`."
    )?;
    Ok(md)
}

/// Energy per window from operation counts: the SNN's SynOps on the engine, the ResNet's MACs.
fn energy_section(md: &mut String, r: &CharsReport, at: usize) -> Result<()> {
    use snn::energy::{CMOS45_MAC, SYNOP_ENERGIES};
    writeln!(md, "\n## Energy per window (estimate, RAB {} mm)\n", r.depths_mm[at])?;
    writeln!(
        md,
        "Operation counts times published energies per operation (`snn::energy`): synaptic and arithmetic work only, no neuron updates, routing, memory traffic or static power. Sources below the table.\n"
    )?;
    writeln!(md, "| model | operations / window | platform | energy / window |")?;
    writeln!(md, "| --- | --- | --- | --- |")?;
    let mut shown_resnet = false;
    for e in &r.entries {
        let s = &e.scores[at];
        match (e.arch, s.synops_per_sample) {
            (Arch::Snn, Some(synops)) => {
                for op in SYNOP_ENERGIES {
                    writeln!(
                        md,
                        "| {} | {:.0} SynOps | {} ({} pJ per {}) | {:.1} uJ |",
                        e.name,
                        synops,
                        op.platform,
                        op.pj_per_op,
                        op.operation,
                        op.nanojoules(synops) / 1e3
                    )?;
                }
            }
            _ if !shown_resnet => {
                if let Some(macs) = e.macs {
                    shown_resnet = true;
                    writeln!(
                        md,
                        "| ResNet lite (every configuration) | {:.0} MACs | {} ({} pJ per {}) | {:.1} uJ |",
                        macs as f64,
                        CMOS45_MAC.platform,
                        CMOS45_MAC.pj_per_op,
                        CMOS45_MAC.operation,
                        CMOS45_MAC.nanojoules(macs as f64) / 1e3
                    )?;
                }
            }
            _ => {}
        }
    }
    writeln!(md)?;
    let mut sources: Vec<&str> = SYNOP_ENERGIES.iter().map(|o| o.source).chain([CMOS45_MAC.source]).collect();
    sources.dedup();
    for src in sources {
        writeln!(md, "- {src}")?;
    }
    Ok(())
}

/// Every model on the windows of `spec`, simulated and labelled once (models that label
/// differently get their own scans of the same seeds); the scores, and the windows (with the
/// counts of scans, skipped scans and printed characters).
pub fn score_all(spec: &CharSetSpec, models: &[&CharModel], progress: &dyn Progress) -> Result<(Vec<Score>, Windows)> {
    let inputs: Vec<&CharInput> = models.iter().map(|m| &m.input).collect();
    let w = if inputs.iter().all(|i| i.labeler == inputs[0].labeler) {
        build_many(spec, &inputs, progress)?
    } else {
        let mut sets = Vec::new();
        let mut last = Windows::default();
        for i in &inputs {
            let (set, w) = build(spec, i, progress)?;
            sets.push(set);
            last = w;
        }
        Windows { sets, ..last }
    };
    let scores: Vec<Score> = models
        .iter()
        .zip(&w.sets)
        .map(|(m, set)| Ok(m.score(set)?.with_first_trial(&w.origin, &set.labels)))
        .collect::<Result<_>>()?;
    let n = scores.first().map_or(0, |s| s.n);
    if scores.iter().any(|s| s.n != n) {
        return Err(Error::WindowCounts { counts: scores.iter().map(|s| s.n).collect() });
    }
    Ok((scores, w))
}

/// Windows classified right: the diagonal of the score's confusion matrix
/// ([`crate::eval::scoring::Confusion::correct`]).
pub fn right(s: &Score) -> usize {
    crate::eval::scoring::Confusion { counts: s.confusion.clone() }.correct() as usize
}

pub fn met(ok: bool) -> &'static str {
    if ok { "met" } else { "**not met**" }
}
