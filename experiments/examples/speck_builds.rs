//! What Speck's arithmetic costs a character model on sensor builds never trained or tested on, one
//! build at a time (SIMULATED, `nominal`): the VAL board (validation text, never a test board)
//! scanned by each of builds 51-60 (training uses 1-4, and 1-24 for the fine-tuning shipped since
//! 2026-11-30; the test 101 and 102), the float model
//! against the same windows in Speck's arithmetic, plainly quantised and after each
//! quantisation-aware fine-tuning. Of all printed characters (a scan the labeler miscounts costs
//! its characters). Nothing is chosen on it; it says how much the chip's cost varies from one
//! sensor build to the next.
//!
//! `cargo run --release -p experiments --example speck_builds -- [TRIALS] [FIRST_BUILD LAST_BUILD]
//! [QAT_DIR] [--control FLOAT_MODEL]` (defaults 10, 51 60 and the shipped `models/nominal/chip/qat`,
//! whose `speck-chars-seed{1,2,3}.safetensors` are the fine-tuned models; under two minutes on two
//! cores). `--control`: a float model fine-tuned as the fine-tuned models were but in floating
//! point (the same data), read on the float engine beside them: what the fine-tuning's data give
//! without the chip.

use corpus::windows::{CharSetSpec, Task, build, snn_set};
use corpus::world::{VALIDATION_SEED, World};
use experiments::eval::chars::CharModel;
use experiments::eval::chip::{ChipChoice, chip_accuracy, map_model};
use experiments::eval::tactile::snn_accuracy;
use pipeline::models::Model;
use sim::BoardKind;
use snn::chip::Chip;
use snn::chip::xylo::{Quantisation, Run};
use snn::engine::Mode;
use std::path::{Path, PathBuf};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let control_path = match args.iter().position(|a| a == "--control") {
        Some(i) if i + 1 < args.len() => {
            let p = PathBuf::from(args.remove(i + 1));
            args.remove(i);
            Some(p)
        }
        Some(_) => return Err("--control needs a model file".into()),
        None => None,
    };
    let qat_dir = match args.len() {
        2 | 4 => PathBuf::from(args.pop().expect("an argument")),
        _ => root.join("models/nominal/chip/qat"),
    };
    let args: Vec<u64> = args.iter().map(|a| a.parse()).collect::<Result<_, _>>()?;
    let (trials, builds) = match args[..] {
        [] => (10, 51..=60),
        [t] => (t, 51..=60),
        [t, a, b] => (t, a..=b),
        _ => {
            return Err(
                "usage: speck_builds [TRIALS] [FIRST_BUILD LAST_BUILD] [QAT_DIR] [--control FLOAT_MODEL]".into()
            );
        }
    };
    // the shipped fine-tuning trains on builds 1-24 (since 2026-11-30): only the held-out builds
    if builds.clone().any(|b| !corpus::world::HELD_OUT_BUILDS.contains(&b)) {
        return Err("the builds must be held-out builds (51-60): never trained or tested on".into());
    }
    let float_path = root.join("models/nominal/chip/speck-chars.safetensors");
    let qat: Vec<PathBuf> = (1..=3).map(|s| qat_dir.join(format!("speck-chars-seed{s}.safetensors"))).collect();
    let float = CharModel::load(&float_path)?;
    let Model::Snn(model) = &float.model else { return Err("the Speck model is an SNN".into()) };
    let choice = ChipChoice { chip: Chip::Speck, quantisation: Quantisation::Global, run: Run::Stepped };
    let plain = map_model(model, &float_path, choice)?.model;
    // a model read on the float model's windows: its input must be the float model's
    let like_float = |p: &Path| -> Result<_, Box<dyn std::error::Error>> {
        let m = pipeline::models::load_snn(p)?;
        if m.preprocess != model.preprocess || m.config.dt_us != model.config.dt_us {
            return Err(format!("{}: not the float model's input", p.display()).into());
        }
        Ok(m)
    };
    let mut tuned = Vec::new();
    for p in &qat {
        tuned.push(map_model(&like_float(p)?, p, choice)?.model);
    }
    let control = control_path.as_deref().map(like_float).transpose()?;
    println!(
        "SIMULATED, `nominal`, VAL board at 8 mm/s and 1.5 mm, {trials} scans per row and build, validation seed; \
         of all printed characters; fine-tuned models: {}\n",
        qat_dir.strip_prefix(&root).unwrap_or(&qat_dir).display()
    );
    if let Some(p) = &control_path {
        println!(
            "float control (fine-tuned in floating point on the same data): {}\n",
            p.strip_prefix(&root).unwrap_or(p).display()
        );
    }
    let (head, rule) = if control.is_some() {
        (" float control | fine-tuned (mean) - control | control - float |", " --- | --- | --- |")
    } else {
        ("", "")
    };
    println!(
        "| build | printed | float | Speck, plain | Speck, fine-tuned (seeds 1-3) | plain - float | fine-tuned (mean) - float |{head}"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- |{rule}");
    let (mut gaps_plain, mut gaps_tuned, mut gaps_control, mut gains_control) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for b in builds {
        let spec = CharSetSpec {
            boards: vec![BoardKind::Val],
            speed_mm_s: 8.0,
            depth_mm: 1.5,
            trials,
            seed: VALIDATION_SEED,
            task: Task::Chars,
            jitter_ms: 0.0,
            world: World { sensors: vec![b], ..World::validation(sim::Realism::Nominal) },
            blank_cells: false,
            sweep: None,
        };
        let (raw, w) = build(&spec, &float.input, &())?;
        let set = snn_set(&float.input, &raw, &(0..raw.len()).collect::<Vec<_>>(), model.config.dt_us, Task::Chars);
        let of_all = |correct: usize| 100.0 * correct as f64 / w.printed.max(1) as f64;
        let f = of_all(snn_accuracy(&model.network, &model.config, &set, Mode::Stepped)?.correct);
        let p = of_all(chip_accuracy(&plain, &set, Run::Stepped)?.0.correct);
        let t: Vec<f64> = tuned
            .iter()
            .map(|c| Ok(of_all(chip_accuracy(c, &set, Run::Stepped)?.0.correct)))
            .collect::<Result<_, experiments::Error>>()?;
        let tm = t.iter().sum::<f64>() / t.len() as f64;
        gaps_plain.push(p - f);
        gaps_tuned.push(tm - f);
        let tail = match &control {
            Some(c) => {
                let fc = of_all(snn_accuracy(&c.network, &c.config, &set, Mode::Stepped)?.correct);
                gaps_control.push(tm - fc);
                gains_control.push(fc - f);
                format!(" {fc:.2}% | {:+.2} | {:+.2} |", tm - fc, fc - f)
            }
            None => String::new(),
        };
        println!(
            "| {b} | {} | {f:.2}% | {p:.2}% | {} | {:+.2} | {:+.2} |{tail}",
            w.printed,
            t.iter().map(|x| format!("{x:.2}%")).collect::<Vec<_>>().join(", "),
            p - f,
            tm - f
        );
    }
    let stats = |g: &[f64]| {
        let m = g.iter().sum::<f64>() / g.len() as f64;
        let sd = (g.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (g.len().max(2) - 1) as f64).sqrt();
        let (lo, hi) = g.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        format!("mean {m:+.2}, sd {sd:.2}, range {lo:+.2} to {hi:+.2}")
    };
    println!("\nplain - float over the builds: {}", stats(&gaps_plain));
    println!("fine-tuned (mean of 3) - float over the builds: {}", stats(&gaps_tuned));
    if control.is_some() {
        println!("fine-tuned (mean of 3) - float control over the builds: {}", stats(&gaps_control));
        println!("float control - float over the builds: {}", stats(&gains_control));
    }
    Ok(())
}
