//! Golden tests of the README's headlines: the search's final models, as shipped, scored again
//! on their test splits on the event-driven engine, against the figures the committed iCub
//! report gives (each seed to the hundredth of a point, and their mean), and the mean against the
//! README's row; Table I's row and the Xylo row run again likewise.

use experiments::eval::tactile::{SplitChoice, eval_split};
use snn::engine::Mode;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The headline's per-seed test accuracies (percent, as printed) and their mean, from the row of
/// `set` in the committed iCub report (docs/results/icub.md, `braille icub-report`).
fn committed(set: &str) -> (Vec<String>, String) {
    let text = std::fs::read_to_string(root().join("docs/results/icub.md")).unwrap();
    let row = text.lines().find(|l| l.starts_with(&format!("| {set} |"))).unwrap();
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    let mean = cells[3].split("**").nth(1).unwrap().trim_end_matches('%').to_string();
    let seeds = cells[4].split(" / ").map(str::to_string).collect();
    (seeds, mean)
}

/// `set`'s headline models (`models/search/{stem}`, seeds 1-3) against the report and the README.
fn check(set: &str, stem: &str) {
    let (seeds, mean) = committed(set);
    assert_eq!(seeds.len(), 3, "{set}: {seeds:?}");
    let mut sum = 0.0;
    for (k, figure) in seeds.iter().enumerate() {
        let file = if k == 0 { format!("{stem}.safetensors") } else { format!("{stem}.seed{}.safetensors", k + 1) };
        let model = root().join("models/search").join(file);
        let (e, _) =
            eval_split(&model, &root().join("data/icub_braille").join(set), SplitChoice::Test, Mode::Stepped).unwrap();
        let pct = 100.0 * e.accuracy;
        assert_eq!(&format!("{pct:.2}"), figure, "{}: seed {}", model.display(), k + 1);
        sum += pct;
    }
    let recomputed = format!("{:.2}", sum / 3.0);
    assert_eq!(recomputed, mean, "{set}: the mean of the seeds");
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(readme.contains(&format!("**{mean}%**")), "the README quotes {set}'s headline {mean}% ({stem})");
}

#[test]
fn raw1350s_headline_is_the_mean_of_its_three_shipped_seeds() {
    check("raw1350", "raw1350-stepscale");
}

#[test]
fn th10s_headline_is_the_mean_of_its_three_shipped_seeds() {
    check("th10", "th10-warmup");
}

/// Golden test of the README's Table I row (SIMULATED): the shipped NormAug ResNet and SNN read
/// the first trial's RAB scans at 1.5 mm again (the report's seed and sensor builds), letter for
/// letter as the committed report (docs/results/nominal/chars.json, `bash scripts/table1.sh`)
/// records them; the report's figure is its confusion's diagonal over every printed character,
/// and the README quotes the two figures.
#[test]
fn table_ones_row_reads_its_first_rab_scans_again() {
    use corpus::windows::{CharSetSpec, Task};
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root().join("docs/results/nominal/chars.json")).unwrap())
            .unwrap();
    let world: corpus::World = serde_json::from_value(report["world"].clone()).unwrap();
    let at = report["depths_mm"].as_array().unwrap().iter().position(|d| d.as_f64() == Some(1.5)).unwrap();
    let printed = report["printed"][at].as_f64().unwrap();
    let mut figures = Vec::new();
    for key in ["normaug", "snn"] {
        let entry = report["entries"].as_array().unwrap().iter().find(|e| e["key"] == key).unwrap();
        let spec = CharSetSpec {
            boards: vec![sim::BoardKind::Rab],
            speed_mm_s: report["speed_mm_s"].as_f64().unwrap(),
            depth_mm: 1.5,
            trials: 1,
            seed: report["seed"].as_u64().unwrap(),
            task: Task::Chars,
            jitter_ms: 0.0,
            world: world.clone(),
            blank_cells: false,
            sweep: None,
        };
        let model = root().join(entry["model"].as_str().unwrap());
        let e = experiments::eval::chars::eval(&model, &spec, &()).unwrap();
        let committed = &entry["scores"][at]["first_trial"];
        assert!(committed.as_array().is_some_and(|a| !a.is_empty()), "{key}: the report records trial 0");
        assert_eq!(&serde_json::to_value(&e.score.first_trial).unwrap(), committed, "{key}: trial 0 read again");
        let confusion = entry["scores"][at]["confusion"].as_array().unwrap();
        let right: u64 = confusion.iter().enumerate().map(|(i, row)| row[i].as_u64().unwrap()).sum();
        let all = entry["accuracy_all"][at].as_f64().unwrap();
        // (to the last bits: the report sums the diagonal in another order)
        assert!(
            (all - right as f64 / printed).abs() < 1e-12,
            "{key}: the figure {all} is the diagonal over every printed character"
        );
        figures.push(format!("{:.2}%", 100.0 * all));
    }
    let quoted = format!("development set {} / {};", figures[0], figures[1]);
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(readme.contains(&quoted), "the README quotes Table I's row as the report gives it: {quoted}");
    // the sealed set's figures as its one committed read gives them (read from its report, never
    // scanned again here: a test that read the sealed set would read it on every run)
    let sealed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root().join("docs/results/nominal/sealed/chars.json")).unwrap())
            .unwrap();
    let at = sealed["depths_mm"].as_array().unwrap().iter().position(|d| d.as_f64() == Some(1.5)).unwrap();
    let figure = |key: &str| {
        let entry = sealed["entries"].as_array().unwrap().iter().find(|e| e["key"] == key).unwrap();
        format!("{:.2}%", 100.0 * entry["accuracy_all"][at].as_f64().unwrap())
    };
    assert_eq!(sealed["world"]["sensors"], serde_json::json!(corpus::world::SEALED_SENSORS));
    let quoted = format!("**{} / {}** on the sealed set", figure("normaug"), figure("snn"));
    assert!(readme.contains(&quoted), "the README quotes Table I's sealed read: {quoted}");
}

/// Golden test of the README's Xylo row (REAL): the shipped Xylo model and its three
/// quantisation-aware fine-tunings, run again on raw1350's test split in Xylo's arithmetic (as
/// `braille chip-report` runs them), give every figure the committed report records
/// (docs/results/chips.json: float, both plain quantisers, each fine-tuning seed on the chip and
/// on the float engine), and the README quotes the plain figures and the seeds' mean.
#[test]
fn xylos_row_runs_its_models_again_in_the_chips_arithmetic() {
    use experiments::eval::chip::{ChipChoice, eval_split_chip};
    use snn::chip::Chip;
    use snn::chip::xylo::{Quantisation, Run};
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root().join("docs/results/chips.json")).unwrap()).unwrap();
    let row = report["arithmetic"].as_array().unwrap().iter().find(|r| r["chip"] == "xylo").unwrap();
    let data = root().join("data/icub_braille/raw1350");
    let on_chip = |model: &Path, quantisation| {
        let choice = ChipChoice { chip: Chip::Xylo, quantisation, run: Run::EventDriven };
        eval_split_chip(model, &data, SplitChoice::Test, choice, false, &()).unwrap().0.eval.accuracy
    };
    let float = |model: &Path| eval_split(model, &data, SplitChoice::Test, Mode::Stepped).unwrap().0.accuracy;
    let same = |got: f64, committed: &serde_json::Value, what: &str| {
        let committed = committed.as_f64().unwrap();
        assert!((got - committed).abs() < 1e-12, "{what}: {got} run again, {committed} committed");
    };
    let base = root().join(row["model"].as_str().unwrap());
    same(float(&base), &row["float"], "float");
    same(on_chip(&base, Quantisation::Global), &row["global"], "Xylo, global quantiser");
    same(on_chip(&base, Quantisation::Channel), &row["channel"], "Xylo, per-channel quantiser");
    let qat = &row["qat"];
    let models = qat["models"].as_array().unwrap();
    assert_eq!(models.len(), 3, "three fine-tuning seeds");
    let mut sum = 0.0;
    for (k, m) in models.iter().enumerate() {
        let model = root().join(m.as_str().unwrap());
        let chip = on_chip(&model, Quantisation::Global);
        same(chip, &qat["chip"][k], &format!("{}: on the chip", model.display()));
        same(float(&model), &qat["float"][k], &format!("{}: on the float engine", model.display()));
        sum += chip;
    }
    let pct = |x: f64| format!("{:.2}%", 100.0 * x);
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let plain =
        format!("{} / {} of 70 plain", pct(row["global"].as_f64().unwrap()), pct(row["channel"].as_f64().unwrap()));
    assert!(readme.contains(&plain), "the README quotes the plain quantisers: {plain}");
    let mean = format!("**{}** fine-tuned", pct(sum / 3.0));
    assert!(readme.contains(&mean), "the README quotes the fine-tuning seeds' mean: {mean}");
}
