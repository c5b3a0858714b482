//! Models for chips as a user meets them: every shipped model exports as trained (its
//! reset-to-zero twin), the chip models pass their chips' rules, graphs are written for each
//! peer's importer, and `braille bench --model` times any model or NIR graph on any events.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn braille(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_braille")).args(args).output().expect("run braille")
}

fn root(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn ok(o: &Output) -> (String, String) {
    let (out, err) = (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(o.status.success(), "{err}");
    (out, err)
}

fn failed(o: &Output) -> String {
    assert!(!o.status.success(), "expected a failure: {}", String::from_utf8_lossy(&o.stdout));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn every_shipped_snn_has_a_twin_that_exports_as_trained_and_chip_models_pass_their_chips() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.nir");
    // the iCub models, the `clean` ones, and those trained at `nominal` (the published tables),
    // each beside its twin, as the registry of shipped models names them
    use pipeline::shipped::{ICUB_DATASETS, Preset, SIMULATED_SNNS, Shipped, Variant};
    let shipped = Shipped::at(root("models"));
    let pairs: Vec<_> = ICUB_DATASETS
        .iter()
        .map(|d| (shipped.icub(d, Variant::Trained), shipped.icub(d, Variant::NirTwin)))
        .chain(Preset::ALL.iter().flat_map(|&p| {
            let shipped = &shipped;
            SIMULATED_SNNS
                .iter()
                .map(move |n| (shipped.model(p, Variant::Trained, n), shipped.model(p, Variant::NirTwin, n)))
        }))
        .collect();
    assert_eq!(pairs.len(), 8);
    for (shipped, twin) in pairs {
        assert!(
            failed(&braille(&["export", "--model", s(&shipped), "--out", s(&out), "--force"])).contains("subtraction")
        );
        ok(&braille(&["export", "--model", s(&twin), "--out", s(&out), "--force"]));
    }
    for (model, target) in [
        ("models/icub/chip/xylo-braille7.safetensors", "xylo"),
        ("models/clean/chip/speck-chars.safetensors", "speck"),
        ("models/nominal/chip/speck-chars.safetensors", "speck"),
        ("models/icub/nir/snn-th10.safetensors", "loihi2"),
        ("models/icub/nir/snn-raw1350.safetensors", "spinnaker2"),
    ] {
        let (_, err) =
            ok(&braille(&["export", "--model", s(&root(model)), "--out", s(&out), "--force", "--target", target]));
        assert!(err.contains("target"), "{err}");
    }
    // a model over a chip's limits: the layer, its node and the limit are named
    let th10 = root("models/icub/nir/snn-th10.safetensors");
    let err = failed(&braille(&["export", "--model", s(&th10), "--out", s(&out), "--force", "--target", "xylo"]));
    assert!(err.contains("layer0.op") && err.contains("16 input channels"), "{err}");
    let chars = root("models/clean/nir/snn-chars.safetensors");
    let err = failed(&braille(&["export", "--model", s(&chars), "--out", s(&out), "--force", "--target", "speck"]));
    assert!(err.contains("layer0.neurons") && err.contains("IF neurons"), "{err}");
    // snnTorch 1.0 reads graphs at 100 us: the convention says where to import
    let (_, err) = ok(&braille(&[
        "export",
        "--model",
        s(&root("models/icub/chip/xylo-braille7.safetensors")),
        "--out",
        s(&out),
        "--force",
        "--convention",
        "snntorch",
    ]));
    assert!(err.contains("snntorch convention: import at dt = 0.0001 s"), "{err}");
}

#[test]
fn bench_times_an_exported_graph_on_its_dataset_as_the_model_file_scores() {
    let dir = tempfile::tempdir().unwrap();
    let model = root("models/icub/chip/xylo-braille7.safetensors");
    let graph = dir.path().join("x.nir");
    ok(&braille(&["export", "--model", s(&model), "--out", s(&graph), "--target", "xylo"]));
    let data = root("data/icub_braille/raw1350");
    let (out, _) = ok(&braille(&[
        "bench",
        "--model",
        s(&graph),
        "--dt-us",
        "10000",
        "--data",
        s(&data),
        "--like",
        s(&model),
        "--streams",
        "2",
        "--json",
    ]));
    let b: serde_json::Value = serde_json::from_str(&out).unwrap();
    let (out, _) = ok(&braille(&["eval", "--data", s(&data), "--model", s(&model), "--json"]));
    let e: serde_json::Value = serde_json::from_str(&out).unwrap();
    // the graph read back runs as the model file scores, sample for sample in count
    assert_eq!(b["samples"], e["n"]);
    assert_eq!(b["accuracy"], e["accuracy"]);
    assert!((b["synops_per_sample"].as_f64().unwrap() - e["synops_per_sample"].as_f64().unwrap()).abs() < 1e-6);
    let l = &b["latency"];
    let q = |k: &str| l[k].as_f64().unwrap();
    assert!(q("p50_ns") <= q("p99_ns") && q("p99_ns") <= q("p999_ns") && q("p999_ns") <= q("max_ns"), "{l}");
    assert_eq!(b["scaling"].as_array().unwrap().len(), 2);
    assert!(b["energy"][0]["nj_per_sample"].as_f64().unwrap() > 0.0);
    // async mode needs LIF or IF layers: a clear refusal for CubaLIF
    let err = failed(&braille(&["bench", "--model", s(&model), "--mode", "async"]));
    assert!(err.contains("async") && err.contains("--mode stepped"), "{err}");
}

#[test]
fn bench_and_run_take_a_peers_graph_on_an_event_file_and_name_events_outside_its_input() {
    let dir = tempfile::tempdir().unwrap();
    // snnTorch's conv graph: 2 x 16 x 16 input (polarity, rows, columns)
    let graph = root("snn/tests/fixtures/nir/conv/conv_snn.nir");
    let events = dir.path().join("e.csv");
    let mut csv = String::from("t_us,x,y,p\n");
    for k in 0..400u32 {
        csv += &format!("{},{},{},{}\n", k * 5, (k * 7) % 16, (k * 3) % 16, k % 2);
    }
    std::fs::write(&events, &csv).unwrap();
    let (out, _) = ok(&braille(&["bench", "--model", s(&graph), "--events", s(&events), "--json"]));
    let b: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(b["source"], "nir_graph");
    assert_eq!(b["input_events_per_sample"].as_f64().unwrap(), 400.0);
    assert!(b["spikes_per_sample"].as_f64().unwrap() > 0.0, "{b}");
    assert!(b["accuracy"].is_null());
    // every spike of every layer, for a spike-for-spike comparison with another simulator
    let spikes = dir.path().join("s.csv");
    let (_, err) = ok(&braille(&["run", "--model", s(&graph), "--events", s(&events), "--out", s(&spikes)]));
    assert!(err.contains("agrees with the time-stepped reference"), "{err}");
    let rows = std::fs::read_to_string(&spikes).unwrap();
    assert!(rows.starts_with("layer,step,neuron\n") && rows.lines().count() > 1);
    let total: usize =
        b["spikes_per_layer_per_sample"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap() as usize).sum();
    assert_eq!(rows.lines().count() - 1, total, "run and bench see the same spikes");
    // an event outside the input: the file, the event and the input's size are named
    csv += "2000,20,3,1\n";
    std::fs::write(&events, &csv).unwrap();
    let err = failed(&braille(&["bench", "--model", s(&graph), "--events", s(&events)]));
    assert!(
        err.contains("e.csv") && err.contains("event 400") && err.contains("x 20") && err.contains("16 x 16"),
        "{err}"
    );
    // a graph with a node the engine cannot run: the file and the node are named
    let mut g = snn::nir::Graph::read(&root("snn/tests/fixtures/nir/dense/dense_snn.nir")).unwrap();
    g.nodes.get_mut("1").unwrap().kind = "Threshold".into();
    let bad = dir.path().join("bad.nir");
    g.write(&bad, false).unwrap();
    let err = failed(&braille(&["bench", "--model", s(&bad)]));
    assert!(err.contains("bad.nir") && err.contains("node `1`") && err.contains("Threshold"), "{err}");
}

#[test]
fn eval_runs_the_xylo_model_in_xylos_arithmetic_stepped_and_event_driven_alike() {
    let model = root("models/icub/chip/xylo-braille7.safetensors");
    let data = root("data/icub_braille/raw1350");
    let run = |how: &str| -> serde_json::Value {
        let (out, _) = ok(&braille(&[
            "eval",
            "--data",
            s(&data),
            "--model",
            s(&model),
            "--split",
            "test",
            "--chip",
            "xylo",
            "--chip-run",
            how,
            "--json",
        ]));
        serde_json::from_str(&out).unwrap()
    };
    let (a, b) = (run("stepped"), run("event-driven"));
    // bit for bit the same: the same predictions, spikes and synaptic operations
    for key in ["correct", "synops_per_sample", "spikes_per_sample"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    assert_eq!(a["n"], 70);
    // the event-driven run updates fewer neurons
    assert!(b["neuron_updates_per_sample"].as_f64() < a["neuron_updates_per_sample"].as_f64());
    let changed: Vec<&str> = a["approximations"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert!(changed.iter().any(|c| c.contains("reset to zero becomes subtraction")), "{changed:?}");
    assert!(changed.iter().any(|c| c.contains("(dash 6)")), "{changed:?}");
    // --trace without --chip is refused by the parser
    let err = failed(&braille(&["eval", "--data", s(&data), "--model", s(&model), "--trace", "x.json"]));
    assert!(err.contains("--chip"), "{err}");
    // bench --chip: the same samples binned into the chip's steps by itself, the same score and work
    let (out, _) = ok(&braille(&["bench", "--model", s(&model), "--data", s(&data), "--chip", "xylo", "--json"]));
    let bench: serde_json::Value = serde_json::from_str(&out).unwrap();
    for key in ["accuracy", "synops_per_sample", "neuron_updates_per_sample"] {
        assert_eq!(bench[key], b[key], "{key}");
    }
    assert_eq!(bench["samples"], 70);
    // beside it, the float engine on the same input, and the ratio of their times
    assert_eq!(bench["float"]["samples"], 70);
    assert!(bench["float"]["accuracy"].as_f64() > bench["accuracy"].as_f64());
    assert!(bench["time_ratio"].as_f64().is_some_and(|r| r > 0.0));
    // a network beyond the chip's sizes is named with the rule
    let raw1350 = root("models/icub/snn-raw1350.safetensors");
    let err = failed(&braille(&["bench", "--model", s(&raw1350), "--chip", "xylo"]));
    assert!(err.contains("snn-raw1350.safetensors") && err.contains("at most 16 input channels"), "{err}");
}

#[test]
fn quantisation_aware_training_scores_its_validation_as_eval_chip_scores_the_written_model() {
    let dir = tempfile::tempdir().unwrap();
    let data = root("data/icub_braille/raw1350");
    let (model, history) = (dir.path().join("q.safetensors"), dir.path().join("h.json"));
    let train = |extra: &[&str]| {
        let mut args = vec!["train", "--data", s(&data), "--recipe", "xylo", "--chip", "xylo", "--hidden", "32"];
        args.extend_from_slice(extra);
        braille(&args)
    };
    ok(&train(&["--epochs", "1", "--out", s(&model), "--history", s(&history), "--quiet"]));
    let h: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&history).unwrap()).unwrap();
    let val = h[0]["val_accuracy"].as_f64().unwrap();
    // the written model in Xylo's arithmetic, on the same validation hold-out (the recipe's seed)
    let (out, _) = ok(&braille(&[
        "eval",
        "--data",
        s(&data),
        "--model",
        s(&model),
        "--split",
        "validation",
        "--val-seed",
        "2",
        "--chip",
        "xylo",
        "--json",
    ]));
    let e: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(e["accuracy"].as_f64().unwrap(), val, "training chose on the chip the model meets");
    // the chip's decays and reset: nothing to approximate but Xylo's readout synapse, delay and cap
    let changed: Vec<&str> = e["approximations"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert!(!changed.iter().any(|c| c.contains("per step becomes") || c.contains("reset to zero")), "{changed:?}");
    // burn's trainer does not run the chip; a model of another shape does not fine-tune
    let err = failed(&train(&["--trainer", "dense", "--epochs", "1", "--out", s(&dir.path().join("d.safetensors"))]));
    assert!(err.contains("sparse trainer"), "{err}");
    let shipped = root("models/icub/chip/xylo-braille7.safetensors");
    let err = failed(&train(&["--init", s(&shipped), "--epochs", "1", "--out", s(&dir.path().join("i.safetensors"))]));
    assert!(err.contains("xylo-braille7.safetensors") && err.contains("layers, sizes or neurons"), "{err}");
}

#[test]
fn eval_chars_runs_the_speck_model_in_specks_arithmetic_stepped_and_event_driven_alike() {
    let model = root("models/nominal/chip/speck-chars.safetensors");
    let run = |how: &str, extra: &[&str]| -> Output {
        let mut args = vec![
            "eval",
            "chars",
            "--arch",
            "snn",
            "--model",
            s(&model),
            "--realism",
            "nominal",
            "--trials",
            "1",
            "--chip",
            "speck",
            "--chip-run",
            how,
            "--json",
        ];
        args.extend_from_slice(extra);
        braille(&args)
    };
    let json = |o: &Output| -> serde_json::Value { serde_json::from_str(&ok(o).0).unwrap() };
    let (a, b) = (json(&run("stepped", &[])), json(&run("event-driven", &[])));
    // bit for bit the same: the same predictions, spikes and synaptic operations
    for key in ["accuracy", "accuracy_all", "synops_per_sample", "spikes_per_sample", "confusion"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    assert_eq!((a["n"].as_u64(), a["printed"].as_u64()), (Some(26), Some(26)));
    assert!(b["neuron_updates_per_sample"].as_f64() < a["neuron_updates_per_sample"].as_f64());
    let changed: Vec<&str> = a["approximations"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert!(changed.iter().any(|c| c.contains("MultiSpike")), "{changed:?}");
    // Speck's cores have one threshold each: no per-channel scales
    let err = failed(&run("stepped", &["--quantisation", "channel"]));
    assert!(err.contains("speck-chars.safetensors") && err.contains("one threshold"), "{err}");
    // a model Speck cannot hold is named with the rule
    let xylo = root("models/icub/chip/xylo-braille7.safetensors");
    let err = failed(&braille(&["bench", "--model", s(&xylo), "--chip", "speck"]));
    assert!(err.contains("xylo-braille7.safetensors") && err.contains("IF neurons only"), "{err}");
    // quantisation-aware training for Speck refuses such a network before it trains
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("q.safetensors");
    let data = root("data/icub_braille/raw1350");
    let err = failed(&braille(&[
        "train",
        "--data",
        s(&data),
        "--recipe",
        "xylo",
        "--chip",
        "speck",
        "--trainer",
        "dense",
        "--epochs",
        "1",
        "--out",
        s(&out),
        "--quiet",
    ]));
    assert!(err.contains("IF neurons only") && !out.exists(), "{err}");
}

#[test]
fn eval_runs_a_recurrent_biased_model_in_loihi_2s_arithmetic_alike_stepped_and_event_driven() {
    // th10's shipped twin: CubaLIF with a bias and a recurrent connection, a leaky-integrator
    // readout; its validation hold-out (never a test split in a test)
    let model = root("models/icub/nir/snn-th10.safetensors");
    let data = root("data/icub_braille/th10");
    let run = |how: &str| -> serde_json::Value {
        let (out, _) = ok(&braille(&[
            "eval",
            "--data",
            s(&data),
            "--model",
            s(&model),
            "--split",
            "validation",
            "--val-seed",
            "2",
            "--chip",
            "loihi2",
            "--chip-run",
            how,
            "--json",
        ]));
        serde_json::from_str(&out).unwrap()
    };
    let (a, b) = (run("stepped"), run("event-driven"));
    for key in ["correct", "synops_per_sample", "spikes_per_sample"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    assert!(b["neuron_updates_per_sample"].as_f64() <= a["neuron_updates_per_sample"].as_f64());
    let changed: Vec<&str> = a["approximations"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert!(changed.iter().any(|c| c.contains("(12 bits)")), "{changed:?}");
    assert!(changed.iter().any(|c| c.contains("bias enters the membrane")), "{changed:?}");
    assert!(changed.iter().any(|c| c.contains("2 synapse blocks")), "{changed:?}");
    assert!(a["accuracy"].as_f64().unwrap() > 0.5, "{}", a["accuracy"]);
    // per-channel scales are refused: a block has one exponent
    let err = failed(&braille(&[
        "eval",
        "--data",
        s(&data),
        "--model",
        s(&model),
        "--chip",
        "loihi2",
        "--quantisation",
        "channel",
    ]));
    assert!(err.contains("one weight exponent"), "{err}");
    // quantisation-aware training for Loihi 2 runs on the dense trainer: the sparse one refuses
    let err = failed(&braille(&[
        "train",
        "--data",
        s(&data),
        "--trainer",
        "sparse",
        "--recipe",
        "xylo",
        "--chip",
        "loihi2",
        "--epochs",
        "1",
        "--out",
        s(&tempfile::tempdir().unwrap().path().join("q.safetensors")),
    ]));
    assert!(err.contains("dense trainer"), "{err}");
}

#[test]
fn eval_words_reads_with_both_snns_in_loihi_2s_arithmetic_and_refuses_a_resnet() {
    // the validation words, one scan per row (never a test board in a test)
    fn args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        let mut a = vec![
            "eval",
            "words",
            "--board",
            "VAL-WORDS",
            "--sensor-builds",
            "training",
            "--trials",
            "1",
            "--speed",
            "16",
            "--realism",
            "nominal",
            "--json",
        ];
        a.extend_from_slice(extra);
        a
    }
    let (out, _) = ok(&braille(&args(&["--chip", "loihi2"])));
    let e: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(e["chip"], serde_json::json!(["loihi2", "global"]));
    assert!(e["word_accuracy"].as_f64().unwrap() > 0.5, "{}", e["word_accuracy"]);
    // the float reader names no chip
    let (out, _) = ok(&braille(&args(&[])));
    let f: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(f.get("chip").is_none());
    // a ResNet runs on no chip; Xylo cannot hold a window's 2560 inputs: each named with its file
    let err = failed(&braille(&args(&["--arch", "resnet", "--chip", "loihi2"])));
    assert!(err.contains("resnet-tiny-segment") && err.contains("ResNet"), "{err}");
    let err = failed(&braille(&args(&["--chip", "xylo"])));
    assert!(err.contains("snn-segment") && err.contains("Xylo"), "{err}");
}
