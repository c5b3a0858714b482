//! Models for neuromorphic chips (`braille chip-report`): what the faithful export costs (every
//! shipped SNN's twin that resets to zero, NIR's reset, against the shipped subtracting model on
//! the same test; a pair that differs in more than the reset is marked), and the chip table: each exportable model against each chip's rules, with its
//! accuracy, work and energy estimates per sample.

use crate::Progress;
use crate::error::Result;
use crate::eval::tactile::{SplitChoice, eval_split};
use crate::eval::words::{WordsSpec, read_scans, score};
use corpus::windows::{CharSetSpec, Task};
use corpus::world::World;
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, TimingMode};
use pipeline::shipped::{ICUB_CHIP, ICUB_DATASETS, Preset, ReaderFiles, Shipped, Variant};
use serde::Serialize;
use sim::BoardKind;
use snn::chip::xylo::{Quantisation, Run};
use snn::chip::{Chip, NumberFormat};
use snn::energy::{CMOS45_ADD, LOIHI_SYNOP, TRUENORTH_SYNOP};
use snn::engine::Mode;
use snn::model_file::Arch;
use snn::nir::{self, ExportOptions, Target};
use std::fmt::Write;
use std::path::{Path, PathBuf};

pub use corpus::world::TEST_SEED;

/// One shipped SNN against its reset-to-zero twin on the same test.
#[derive(Debug, Clone, Serialize)]
pub struct FaithfulRow {
    pub model: String,
    pub test: String,
    pub data: &'static str,
    /// The shipped model (reset by subtraction) and the twin (reset to zero), the headline metric.
    pub subtract: f64,
    pub zero: f64,
    /// Points, zero minus subtract.
    pub difference: f64,
    /// The same with the conditional metric beside it, where there is one.
    pub detail: String,
    /// Where the twin differs from the shipped model in more than the reset (a shipped model
    /// retrained after its twin, a twin distilled from other models): the recipe's fields, the
    /// teachers, or why the recipes could not be compared; empty for a like-for-like pair.
    pub recipe_differences: Vec<String>,
}

/// What a target's check said.
#[derive(Debug, Clone, Serialize)]
pub struct TargetCheck {
    pub target: Target,
    pub passes: bool,
    /// The rule broken.
    pub rule: Option<String>,
}

/// One exportable model: what it reads, how well, its work, and the chips whose rules it meets.
#[derive(Debug, Clone, Serialize)]
pub struct ChipRow {
    pub model: String,
    pub reads: String,
    pub data: &'static str,
    pub accuracy: f64,
    pub n: usize,
    pub input_events_per_sample: f64,
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    pub neurons: usize,
    pub synapses: usize,
    /// Nanojoules per sample at Loihi's, TrueNorth's and a 45 nm adder's energy per SynOp.
    pub loihi_nj: f64,
    pub truenorth_nj: f64,
    pub cmos45_nj: f64,
    /// It exports to NIR as trained (no reset by subtraction).
    pub exports: bool,
    pub targets: Vec<TargetCheck>,
}

/// A model in one chip's arithmetic beside its floating-point score on the same test.
#[derive(Debug, Clone, Serialize)]
pub struct ArithmeticRow {
    pub model: String,
    pub chip: Chip,
    pub test: String,
    pub data: &'static str,
    pub n: usize,
    /// The float engine's accuracy.
    pub float: f64,
    /// After plain quantisation (the mapping, then Rockpool's global and per-channel quantisers).
    pub global: f64,
    /// `None` where the chip has no per-channel scales (Speck: one threshold per core).
    pub channel: Option<f64>,
    pub format: NumberFormat,
    /// Bit shifts of the input, recurrent and output weights (global quantisation).
    pub weight_shifts: [u8; 3],
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    /// The float engine's, for comparison.
    pub float_spikes_per_sample: f64,
    pub approximations: Vec<String>,
    /// After quantisation-aware fine-tuning, if the model has fine-tuned versions.
    pub qat: Option<QatScores>,
}

/// A model's quantisation-aware fine-tunings for a chip (`qat/NAME-seedS.safetensors` beside
/// it, one per fine-tuning seed, trained for the global quantiser), on the same test.
#[derive(Debug, Clone, Serialize)]
pub struct QatScores {
    pub models: Vec<String>,
    /// In the chip's arithmetic (global quantisation), per model.
    pub chip: Vec<f64>,
    /// On the float engine, per model (its neurons are the chip's, single spikes per step).
    pub float: Vec<f64>,
    pub synops_per_sample: Vec<f64>,
    /// How they were fine-tuned, from their recipes (epochs, learning rate, the training scans'
    /// sensor builds when not the usual ones); one entry per distinct recipe apart from the seed.
    pub fine_tuning: Vec<String>,
}

impl QatScores {
    pub fn chip_mean(&self) -> f64 {
        self.chip.iter().sum::<f64>() / self.chip.len().max(1) as f64
    }
}

/// The quantisation-aware fine-tunings of the model at `path`: `qat/STEM-seed*.safetensors`
/// beside it, in seed order.
pub fn qat_models(path: &Path) -> Vec<PathBuf> {
    let (Some(dir), Some(stem)) = (path.parent(), path.file_stem().and_then(|s| s.to_str())) else {
        return Vec::new();
    };
    let prefix = format!("{stem}-seed");
    let mut found: Vec<(u64, PathBuf)> = std::fs::read_dir(dir.join("qat"))
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_str()?.to_string();
            let seed = name.strip_prefix(&prefix)?.strip_suffix(".safetensors")?.parse().ok()?;
            Some((seed, e.path()))
        })
        .collect();
    found.sort();
    found.into_iter().map(|(_, p)| p).collect()
}

#[derive(Debug, Clone, Serialize)]
pub struct ChipReport {
    pub faithful: Vec<FaithfulRow>,
    pub chips: Vec<ChipRow>,
    /// The models that pass a modelled chip's rules, in that chip's arithmetic.
    pub arithmetic: Vec<ArithmeticRow>,
    pub trials: u64,
    /// The simulator's preset of the simulated models and tests.
    pub realism: sim::Realism,
}

/// What to put in the report: the shipped models (as trained, their reset-to-zero twins, the
/// chip models; [`pipeline::shipped`]), the iCub data, scans per simulated board row and the
/// simulator's preset, whose models the simulated tests read.
#[derive(Debug, Clone)]
pub struct ChipSpec {
    pub models: Shipped,
    pub icub: PathBuf,
    pub trials: u64,
    pub realism: sim::Realism,
}

impl ChipSpec {
    /// The file of shipped model `name` in `variant`: the iCub models' folder for the models of
    /// the iCub recordings, else the preset's.
    pub fn path(&self, variant: Variant, name: &str) -> Result<PathBuf> {
        if ICUB_DATASETS.iter().any(|d| name == format!("snn-{d}")) || name == ICUB_CHIP {
            return Ok(self.models.icub_dir(variant).join(format!("{name}.safetensors")));
        }
        Ok(self.models.model(Preset::of_name(&self.realism.to_string())?, variant, name))
    }
}

fn chars_spec(trials: u64, realism: sim::Realism) -> CharSetSpec {
    CharSetSpec {
        boards: vec![BoardKind::Rab],
        speed_mm_s: 8.0,
        depth_mm: 1.5,
        trials,
        seed: TEST_SEED,
        task: Task::Chars,
        jitter_ms: 0.0,
        world: World::test(realism),
        blank_cells: false,
        sweep: None,
    }
}

/// Accuracy, work and size of a model on its test.
struct Scored {
    reads: String,
    data: &'static str,
    accuracy: f64,
    detail: String,
    n: usize,
    events: f64,
    synops: f64,
    spikes: f64,
}

/// A model on its own test: a tactile model on its dataset's test split, a character classifier
/// on RAB at 1.5 mm (over every printed character).
fn score_model(path: &Path, spec: &ChipSpec, progress: &dyn Progress) -> Result<Scored> {
    let (icub, trials) = (&spec.icub, spec.trials);
    let model = pipeline::models::load_snn(path)?;
    // what the model reads, by its typed header: a bad header is an error, not a character model
    if let pipeline::models::Preprocessing::Tactile(enc) =
        pipeline::models::Preprocessing::of_header(&model.preprocess, path)?
    {
        // the dataset folder the model was trained on, as its provenance names it
        let set = model.provenance["data"].as_str().ok_or_else(|| crate::Error::Model {
            path: path.to_path_buf(),
            what: "the provenance names no dataset folder".into(),
        })?;
        let (e, _) = eval_split(path, &icub.join(set), SplitChoice::Test, Mode::Stepped)?;
        let classes = enc.classes.as_ref().map_or(String::new(), |c| format!(", {} classes", c.len()));
        return Ok(Scored {
            reads: format!("iCub {set} test split{classes}"),
            data: "REAL",
            accuracy: e.accuracy,
            detail: format!("{}/{}", e.correct, e.n),
            n: e.n,
            events: e.input_events_per_sample,
            synops: e.synops_per_sample,
            spikes: e.spikes_per_sample,
        });
    }
    let e = crate::eval::chars::eval(path, &chars_spec(trials, spec.realism), progress)?;
    Ok(Scored {
        reads: "RAB characters at 1.5 mm, of all printed".into(),
        data: "SIMULATED",
        accuracy: e.accuracy_all,
        detail: format!(
            "{:.2}% of {} printed; {:.2}% of {} windows found",
            100.0 * e.accuracy_all,
            e.printed,
            100.0 * e.score.accuracy,
            e.score.n
        ),
        n: e.printed,
        events: e.score.input_events_per_sample.unwrap_or(0.0),
        synops: e.score.synops_per_sample.unwrap_or(0.0),
        spikes: e.score.spikes_per_sample.unwrap_or(0.0),
    })
}

/// The shipped SNNs (their file names under both folders).
pub const SHIPPED: [&str; 4] = ["snn-raw1350", "snn-th10", "snn-chars", "snn-words"];
/// The chip models under the chip folder.
pub const CHIP_MODELS: [&str; 2] = ["speck-chars", "xylo-braille7"];

/// Runs every comparison and check.
pub fn run(spec: &ChipSpec, progress: &dyn Progress) -> Result<ChipReport> {
    let mut faithful = Vec::new();
    for name in SHIPPED {
        let (trained, twin) = (spec.path(Variant::Trained, name)?, spec.path(Variant::NirTwin, name)?);
        let a = score_model(&trained, spec, progress)?;
        let b = score_model(&twin, spec, progress)?;
        progress.note(&format!("{name}: subtract {:.2}%, zero {:.2}%", 100.0 * a.accuracy, 100.0 * b.accuracy));
        let recipe_differences = recipe_differences(&trained, &twin)?;
        faithful.push(FaithfulRow {
            model: name.into(),
            test: a.reads.clone(),
            data: a.data,
            subtract: a.accuracy,
            zero: b.accuracy,
            difference: 100.0 * (b.accuracy - a.accuracy),
            detail: format!("subtract {}; zero {}", a.detail, b.detail),
            recipe_differences,
        });
    }
    // the reading pair (segmentation and classifier SNNs) on the EV board, the same scans for both
    let words = WordsSpec {
        board: BoardKind::Ev,
        speed_mm_s: 16.0,
        speed_variation: 0.0,
        depth_mm: 1.5,
        trials: spec.trials,
        seed: TEST_SEED,
        world: World::test(spec.realism),
    };
    let readers = [Variant::Trained, Variant::NirTwin]
        .map(|variant| {
            let words = spec.path(variant, "snn-words")?;
            let dir = words.parent().unwrap_or(Path::new("."));
            let ReaderFiles { segmenter, classifier } = pipeline::shipped::reader_in(dir, Arch::Snn);
            ReaderModels::load(&segmenter, &classifier, SnnRunner::Sliding).map_err(crate::Error::from)
        })
        .into_iter()
        .collect::<Result<Vec<_>>>()?;
    let lines = read_scans(&words, &readers.iter().collect::<Vec<_>>(), &[TimingMode::Estimated], progress)?;
    // the pair's two networks, each against its twin
    let mut pair_differences = Vec::new();
    for name in ["snn-segment", "snn-words"] {
        let (trained, twin) = (spec.path(Variant::Trained, name)?, spec.path(Variant::NirTwin, name)?);
        for d in recipe_differences(&trained, &twin)? {
            pair_differences.push(format!("{name}: {d}"));
        }
    }
    let acc = |k: usize, spell: Spell| {
        let s = score(Arch::Snn, TimingMode::Estimated, k, &lines, words.condition());
        s.by_spell.iter().find(|b| b.spell == spell).map_or(0.0, |b| b.word_accuracy)
    };
    for spell in [Spell::Lexicon, Spell::None] {
        let (a, b) = (acc(0, spell), acc(1, spell));
        faithful.push(FaithfulRow {
            model: "snn-segment + snn-words".into(),
            test: format!("EV board read at 16 mm/s, speed estimated, spelling {spell:?}: word accuracy (1 - WER) over all printed words"),
            data: "SIMULATED",
            subtract: a,
            zero: b,
            difference: 100.0 * (b - a),
            detail: format!("{} scans", lines.len()),
            recipe_differences: pair_differences.clone(),
        });
    }
    let mut chips = Vec::new();
    let candidates: Vec<PathBuf> = CHIP_MODELS
        .iter()
        .map(|n| spec.path(Variant::Chip, n))
        .chain(["snn-raw1350", "snn-th10", "snn-chars"].iter().map(|n| spec.path(Variant::NirTwin, n)))
        .collect::<Result<_>>()?;
    for path in candidates {
        let model = pipeline::models::load_snn(&path)?;
        let s = score_model(&path, spec, progress)?;
        let exports = nir::export(&model.network, &ExportOptions::new(model.config.dt_us as f64 * 1e-6)).is_ok();
        let targets = Target::CHIPS
            .iter()
            .map(|&t| match nir::check_target(&model.network, t) {
                Ok(()) => TargetCheck { target: t, passes: true, rule: None },
                Err(e) => TargetCheck {
                    target: t,
                    passes: false,
                    rule: Some(e.to_string().trim_start_matches("<target>: ").to_string()),
                },
            })
            .collect();
        let net = &model.network;
        chips.push(ChipRow {
            model: path.display().to_string(),
            reads: s.reads,
            data: s.data,
            accuracy: s.accuracy,
            n: s.n,
            input_events_per_sample: s.events,
            synops_per_sample: s.synops,
            spikes_per_sample: s.spikes,
            neurons: net.layers.iter().filter(|l| l.neurons.is_some()).map(|l| l.op.n_out()).sum(),
            synapses: net.weights().iter().map(|w| w.weight.len() + w.recurrent.as_ref().map_or(0, Vec::len)).sum(),
            loihi_nj: LOIHI_SYNOP.nanojoules(s.synops),
            truenorth_nj: TRUENORTH_SYNOP.nanojoules(s.synops),
            cmos45_nj: CMOS45_ADD.nanojoules(s.synops),
            exports,
            targets,
        });
    }
    let arithmetic = arithmetic_rows(spec, &chips, progress)?;
    Ok(ChipReport { faithful, chips, arithmetic, trials: spec.trials, realism: spec.realism })
}

/// A model's score in a chip's arithmetic.
struct InChip {
    accuracy: f64,
    synops: f64,
    spikes: f64,
    approximations: Vec<String>,
    weight_shifts: [u8; 3],
}

/// Every model that passes a modelled chip's rules, on its test in that chip's arithmetic (each
/// quantiser the chip has), beside the float engine: a tactile model on its dataset's test split,
/// a character classifier on the chip table's simulated windows.
fn arithmetic_rows(spec: &ChipSpec, chips: &[ChipRow], progress: &dyn Progress) -> Result<Vec<ArithmeticRow>> {
    use crate::eval::chip::{ChipChoice, eval_split_chip};
    let mut rows = Vec::new();
    for c in chips {
        let path = Path::new(&c.model);
        let model = pipeline::models::load_snn(path)?;
        let real = c.data == "REAL";
        let dir = spec.icub.join(model.provenance["data"].as_str().unwrap_or_default());
        let float = if real { Some(eval_split(path, &dir, SplitChoice::Test, Mode::Stepped)?.0) } else { None };
        for chip in Chip::ALL {
            let target = match chip {
                Chip::Xylo => Target::Xylo,
                Chip::Speck => Target::Speck,
                Chip::Loihi2 => Target::Loihi2,
            };
            if !c.targets.iter().any(|t| t.target == target && t.passes) {
                continue;
            }
            // accuracy, SynOps and spikes per sample, approximations and shifts in the chip
            let run = |model: &Path, quantisation| -> Result<InChip> {
                let choice = ChipChoice { chip, quantisation, run: Run::EventDriven };
                if real {
                    let (e, _, _) = eval_split_chip(model, &dir, SplitChoice::Test, choice, false, progress)?;
                    Ok(InChip {
                        accuracy: e.eval.accuracy,
                        synops: e.eval.synops_per_sample,
                        spikes: e.eval.spikes_per_sample,
                        approximations: e.approximations,
                        weight_shifts: e.weight_shifts,
                    })
                } else {
                    let (e, _) = crate::eval::chars::eval_chip(
                        model,
                        &chars_spec(spec.trials, spec.realism),
                        choice,
                        false,
                        progress,
                    )?;
                    let sc = &e.eval.score;
                    Ok(InChip {
                        accuracy: e.eval.accuracy_all,
                        synops: sc.synops_per_sample.unwrap_or(0.0),
                        spikes: sc.spikes_per_sample.unwrap_or(0.0),
                        approximations: e.approximations,
                        weight_shifts: [0; 3],
                    })
                }
            };
            let InChip { accuracy: global, synops, spikes, approximations, weight_shifts } =
                run(path, Quantisation::Global)?;
            let channel = match chip {
                Chip::Xylo => Some(run(path, Quantisation::Channel)?.accuracy),
                Chip::Speck | Chip::Loihi2 => None,
            };
            // the fine-tuned models made for this chip (their recipe names it)
            // each with how it was fine-tuned
            let tuned: Vec<(PathBuf, String)> = qat_models(path)
                .into_iter()
                .filter_map(|m| {
                    let recipe = pipeline::models::load_snn(&m).ok()?.provenance["recipe"].clone();
                    (recipe["chip"] == serde_json::json!(chip)).then(|| (m, fine_tuning(&recipe)))
                })
                .collect();
            let qat = if tuned.is_empty() {
                None
            } else {
                let mut q = QatScores {
                    models: Vec::new(),
                    chip: Vec::new(),
                    float: Vec::new(),
                    synops_per_sample: Vec::new(),
                    fine_tuning: Vec::new(),
                };
                for (m, how) in &tuned {
                    let InChip { accuracy: acc, synops, .. } = run(m, Quantisation::Global)?;
                    let f = if real {
                        eval_split(m, &dir, SplitChoice::Test, Mode::Stepped)?.0.accuracy
                    } else {
                        score_model(m, spec, progress)?.accuracy
                    };
                    q.models.push(m.display().to_string());
                    q.chip.push(acc);
                    q.float.push(f);
                    q.synops_per_sample.push(synops);
                    if !q.fine_tuning.contains(how) {
                        q.fine_tuning.push(how.clone());
                    }
                }
                Some(q)
            };
            rows.push(ArithmeticRow {
                model: c.model.clone(),
                chip,
                test: c.reads.clone(),
                data: c.data,
                n: c.n,
                float: float.as_ref().map_or(c.accuracy, |f| f.accuracy),
                global,
                channel,
                format: chip.format(),
                weight_shifts,
                synops_per_sample: synops,
                spikes_per_sample: spikes,
                float_spikes_per_sample: float.as_ref().map_or(c.spikes_per_sample, |f| f.spikes_per_sample),
                approximations,
                qat,
            });
        }
    }
    Ok(rows)
}

/// The centring band given to a model after training (`braille set-band`), the last one
/// recorded in its provenance.
fn band_after_training(p: &serde_json::Value) -> Option<&serde_json::Value> {
    p["input_changes"].as_array().and_then(|c| c.last()).map(|last| &last["band_rows"])
}

/// How two models' inputs after training differ, if they do: the same band given to both (as
/// `scripts/train_nir.sh` gives the words twin the shipped model's) is no difference.
fn band_difference(shipped: &serde_json::Value, twin: &serde_json::Value) -> Option<String> {
    let (a, b) = (band_after_training(shipped), band_after_training(twin));
    let show = |b: Option<&serde_json::Value>| b.map_or("none".to_string(), |v| format!("band {v}"));
    (a != b).then(|| format!("the input after training (shipped {}, twin {})", show(a), show(b)))
}

/// How a model was taught, if it was distilled (`train --distill-from`): its teachers and mix,
/// read from its provenance.
fn distilled_from(p: &serde_json::Value) -> Option<String> {
    let d = p.get("distill")?;
    Some(format!(
        "its training: the twin was distilled from {} (weight {}, temperature {})",
        d["teacher"].as_str().unwrap_or("teachers not recorded"),
        d["weight"],
        d["temperature"]
    ))
}

/// The fields in which two models' recipes differ, the reset apart (a twin's one change), and
/// their centring bands given after training, when they differ. Each recipe is read as a recipe
/// first, so that a field an older model left out counts as its default; a model that records no
/// recipe is named instead.
fn recipe_differences(trained: &Path, twin: &Path) -> Result<Vec<String>> {
    let (pa, pb) = (pipeline::models::load_snn(trained)?.provenance, pipeline::models::load_snn(twin)?.provenance);
    let mut out: Vec<String> = band_difference(&pa, &pb).into_iter().collect();
    out.extend(distilled_from(&pb));
    // a recipe as its fields read back (defaults for fields an older model left out)
    let read = |p: &serde_json::Value| {
        let raw = &p["recipe"];
        (!raw.is_null()).then(|| {
            serde_json::from_value::<crate::train::recipe::SnnRecipe>(raw.clone())
                .ok()
                .and_then(|r| serde_json::to_value(r).ok())
                .unwrap_or_else(|| raw.clone())
        })
    };
    let (a, b) = match (read(&pa), read(&pb)) {
        (Some(a), Some(b)) => (a, b),
        (a, _) => {
            let which = if a.is_none() { trained } else { twin };
            out.push(format!("recipes not compared: {} records none", which.display()));
            return Ok(out);
        }
    };
    let empty = serde_json::Map::new();
    let (a, b) = (a.as_object().unwrap_or(&empty), b.as_object().unwrap_or(&empty));
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).filter(|k| k.as_str() != "reset").collect();
    keys.sort();
    keys.dedup();
    out.extend(keys.into_iter().filter(|k| a.get(*k) != b.get(*k)).cloned());
    Ok(out)
}

/// A fine-tuning recipe in a few words: epochs, learning rate, and the sensor builds of its
/// training scans when they are not the training builds.
fn fine_tuning(recipe: &serde_json::Value) -> String {
    let mut s = format!("{} epochs, lr {}", recipe["epochs"], recipe["lr"]);
    if let Some(builds) = recipe["train_builds"].as_array() {
        let builds: Vec<u64> = builds.iter().filter_map(|b| b.as_u64()).collect();
        s.push_str(&format!(", scans from sensor builds {}", corpus::world::format_builds(&builds)));
    }
    s
}

/// The report as Markdown.
pub fn markdown(r: &ChipReport) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Models for neuromorphic chips\n");
    let _ = writeln!(
        s,
        "Regenerate: `braille chip-report --realism {} --out docs/results` (models from `bash scripts/train_nir.sh` and `bash scripts/train_chips.sh`, `REALISM={}` for the simulated ones). Simulated tests: {} scans per board row, seed {TEST_SEED}, the `{}` world (its test sensor builds beyond `clean`), with the models trained there. REAL rows are the iCub recordings' fixed test splits.\n",
        r.realism, r.realism, r.trials, r.realism
    );
    let _ = writeln!(s, "## What the faithful export costs\n");
    let _ = writeln!(
        s,
        "Every shipped SNN resets by subtraction, which NIR cannot write. Each was retrained by the same recipe with one change, neurons that reset to zero (NIR's reset to `v_reset`), into a `nir/` folder beside it (`models/icub/nir/`, `models/REALISM/nir/`); nothing else was chosen. The iCub twins are instead, since 2026-12-04, each dataset's twin of record: its searched twin recipe distilled from the subtracting headline's models (docs/nir.md, where the like-for-like searched pairs give the reset's cost). Accuracy on the same test. Where a shipped model was retrained or given a centring band (`braille set-band`) after its twin was made, the pair differs in more than the reset, and the row says in what (the recipes' fields and the bands, read from the models' files): such a row is not the reset's cost.\n"
    );
    let _ = writeln!(
        s,
        "| model | test | data | subtract (shipped) | reset to zero (exports) | difference (points) | detail |"
    );
    let _ = writeln!(s, "| --- | --- | --- | --- | --- | --- | --- |");
    for f in &r.faithful {
        let (unknown, differ): (Vec<&String>, Vec<&String>) =
            f.recipe_differences.iter().partition(|d| d.starts_with("recipes not compared"));
        let mut detail = if differ.is_empty() {
            f.detail.clone()
        } else {
            let differ: Vec<&str> = differ.iter().map(|d| d.as_str()).collect();
            format!("**not like for like**: besides the reset the pair differs in {}; {}", differ.join(", "), f.detail)
        };
        for u in unknown {
            detail.push_str(&format!("; {u}"));
        }
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2}% | {:.2}% | {:+.2} | {} |",
            f.model,
            f.test,
            f.data,
            100.0 * f.subtract,
            100.0 * f.zero,
            f.difference,
            detail
        );
    }
    let _ = writeln!(s, "\n## Chip table\n");
    let _ = writeln!(
        s,
        "Each model that exports as trained, against each chip's rules (`braille export --target`; the rules and their sources in docs/nir.md). Work per sample is the event-driven engine's (stepped mode): SynOps (one weight added to one neuron) and spikes. Energy = SynOps x a published energy per SynOp (Loihi 23.6 pJ, TrueNorth 26 pJ, a 45 nm 32-bit add 0.9 pJ): the synaptic work only, no neuron updates, routing or static power; none is given for Speck, Xylo, Loihi 2 or SpiNNaker 2, whose per-SynOp figures could not be verified here.\n"
    );
    let chips: Vec<&str> = Target::CHIPS.iter().map(|t| t.name()).collect();
    let _ = writeln!(
        s,
        "| model | reads | data | accuracy | neurons | synapses | input events | SynOps | spikes | Loihi nJ | TrueNorth nJ | 45 nm nJ | {} |",
        chips.join(" | ")
    );
    let _ = writeln!(s, "|{}", " --- |".repeat(12 + chips.len()));
    for c in &r.chips {
        let marks: Vec<&str> = c.targets.iter().map(|t| if t.passes { "passes" } else { "no" }).collect();
        let _ = writeln!(
            s,
            "| `{}` | {} | {} | {:.2}% (n = {}) | {} | {} | {:.0} | {:.0} | {:.0} | {:.1} | {:.1} | {:.2} | {} |",
            c.model,
            c.reads,
            c.data,
            100.0 * c.accuracy,
            c.n,
            c.neurons,
            c.synapses,
            c.input_events_per_sample,
            c.synops_per_sample,
            c.spikes_per_sample,
            c.loihi_nj,
            c.truenorth_nj,
            c.cmos45_nj,
            marks.join(" | ")
        );
    }
    if !r.arithmetic.is_empty() {
        let _ = writeln!(s, "\n## In the chip's arithmetic\n");
        let _ = writeln!(
            s,
            "Each model that passes a modelled chip's rules, mapped into that chip's number formats and run as the chip computes (`braille eval --chip`; the formats and their sources in docs/chips.md), on the same test as the float engine. Plain quantisation, no retraining: on Xylo the mapping (decays to bit shifts, the chip's order of operations), then Rockpool's global or per-channel 8-bit quantiser; on Speck Sinabs's discretisation (one scale per core for its 8-bit weights and 16-bit threshold) and Sinabs's model of the chip's neurons (several spikes per step); on Loihi 2 Lava's fixed-point LIF (8-bit weights with one exponent per synapse block, 24-bit state, 12-bit decays, thresholds in (2^9, 2^10] at the weights' full 8 bits), each layer one step later than the one before, the sample run on for that latency. The engine's Xylo arithmetic agrees spike for spike with SynSense's XyloSim (`scripts/chips/xylosim_check.py`, python/tests/test_xylosim.py), its Speck arithmetic with SynSense's Sinabs (`scripts/chips/sinabs_check.py`, python/tests/test_sinabs.py), its Loihi 2 arithmetic with Intel's Lava (`scripts/chips/lava_check.py`, python/tests/test_lava.py). SpiNNaker 2 is not modelled: its neurons are programs on ARM cores, and its toolchain (py-spinnaker2) is neither on PyPI nor readable here, so no number format could be taken from the vendor's code.\n"
        );
        let _ = writeln!(
            s,
            "| model | chip | test | data | float | global quantisation | per-channel quantisation | weight / state bits | weight shifts (in, rec, out) | SynOps | spikes (float) |"
        );
        let _ = writeln!(s, "|{}", " --- |".repeat(11));
        for a in &r.arithmetic {
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} | {:.2}% (n = {}) | {:.2}% | {} | {} / {} | {:?} | {:.0} | {:.0} ({:.0}) |",
                a.model,
                a.chip,
                a.test,
                a.data,
                100.0 * a.float,
                a.n,
                100.0 * a.global,
                a.channel.map_or("none on this chip".to_string(), |c| format!("{:.2}%", 100.0 * c)),
                a.format.weight_bits,
                a.format.state_bits,
                a.weight_shifts,
                a.synops_per_sample,
                a.spikes_per_sample,
                a.float_spikes_per_sample
            );
        }
        let tuned: Vec<&ArithmeticRow> = r.arithmetic.iter().filter(|a| a.qat.is_some()).collect();
        if !tuned.is_empty() {
            let _ = writeln!(s, "\n### After quantisation-aware fine-tuning\n");
            let _ = writeln!(
                s,
                "Each model fine-tuned for the chip from its float weights (`braille train --chip`, docs/chips.md: the chip's decays and reset, every training step's forward pass in the chip's arithmetic with that step's weights quantised, straight-through gradients, checkpoints chosen on the chip's validation accuracy), one run per fine-tuning seed, scored once on the same test in the chip's arithmetic (global quantisation, as trained). The headline is the mean over the seeds; each seed's figure beside it. Float: the fine-tuned models on the float engine, whose neurons send one spike per step where the chip sends several.\n"
            );
            let _ = writeln!(
                s,
                "| model | chip | test | float (as trained) | plain quantisation (global) | quantisation-aware, mean of seeds | spread (min-max, points) | per seed | fine-tuned on the float engine | SynOps | fine-tuning |"
            );
            let _ = writeln!(s, "|{}", " --- |".repeat(11));
            for a in tuned {
                let q = a.qat.as_ref().expect("filtered");
                let pct = |v: &[f64]| v.iter().map(|x| format!("{:.2}%", 100.0 * x)).collect::<Vec<_>>().join(", ");
                let (lo, hi) =
                    q.chip.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
                let synops = q.synops_per_sample.iter().sum::<f64>() / q.synops_per_sample.len().max(1) as f64;
                let _ = writeln!(
                    s,
                    "| `{}` | {} | {} | {:.2}% (n = {}) | {:.2}% | **{:.2}%** ({} seeds) | {:.2} | {} | {} | {:.0} | {} |",
                    a.model,
                    a.chip,
                    a.test,
                    100.0 * a.float,
                    a.n,
                    100.0 * a.global,
                    100.0 * q.chip_mean(),
                    q.chip.len(),
                    100.0 * (hi - lo),
                    pct(&q.chip),
                    pct(&q.float),
                    synops,
                    q.fine_tuning.join("; ")
                );
            }
        }
        let _ = writeln!(s, "\nWhat each mapping changed:\n");
        for a in &r.arithmetic {
            let _ = writeln!(s, "- `{}` on {}: {}", a.model, a.chip, a.approximations.join("; "));
        }
    }
    let _ = writeln!(s, "\nWhy a model fails a chip:\n");
    for c in &r.chips {
        for t in c.targets.iter().filter(|t| !t.passes) {
            let _ = writeln!(s, "- `{}` on {}: {}", c.model, t.target.name(), t.rule.as_deref().unwrap_or(""));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::{band_difference, distilled_from};
    use serde_json::json;

    #[test]
    fn a_distilled_twin_names_its_teachers_and_a_plain_one_nothing() {
        let taught =
            json!({ "distill": { "teacher": "a.safetensors, b.safetensors", "weight": 0.5, "temperature": 4.0 } });
        assert_eq!(
            distilled_from(&taught).as_deref(),
            Some(
                "its training: the twin was distilled from a.safetensors, b.safetensors (weight 0.5, temperature 4.0)"
            )
        );
        assert_eq!(distilled_from(&json!({ "recipe": {} })), None);
    }

    #[test]
    fn a_band_given_to_both_models_is_no_difference_and_one_given_to_one_is() {
        let banded = json!({ "input_changes": [{ "band_rows": [4, 116] }, { "band_rows": [12, 100] }] });
        let same = json!({ "input_changes": [{ "band_rows": [12, 100] }] });
        let other = json!({ "input_changes": [{ "band_rows": [4, 116] }] });
        let none = json!({});
        assert_eq!(band_difference(&banded, &same), None);
        assert_eq!(band_difference(&none, &none), None);
        assert_eq!(
            band_difference(&banded, &none).as_deref(),
            Some("the input after training (shipped band [12,100], twin none)")
        );
        assert_eq!(
            band_difference(&same, &other).as_deref(),
            Some("the input after training (shipped band [12,100], twin band [4,116])")
        );
    }
}
