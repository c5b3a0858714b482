//! NIR import against the snnTorch / Norse golden outputs (tests/fixtures/nir, see its README),
//! export round trips, and target profiles.

use snn::engine::{Engine, Mode};
use snn::network::{Network, forward_dense, forward_dense_traced, random_input};
use snn::nir::{self, Convention, ExportOptions, Graph, ImportOptions, ImportReset, SubtractExport, Target};
use std::path::{Path, PathBuf};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nir").join(rel)
}

/// A little-endian NumPy array (`|u1` or `<f4`, C order) as f32.
fn npy(rel: &str) -> (Vec<usize>, Vec<f32>) {
    let b = std::fs::read(fixture(rel)).unwrap();
    assert_eq!(&b[..6], b"\x93NUMPY");
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
    let shape_txt = header.split("'shape': (").nth(1).unwrap().split(')').next().unwrap();
    let shape: Vec<usize> = shape_txt.split(',').filter_map(|s| s.trim().parse().ok()).collect();
    let body = &b[10 + hlen..];
    let data = if header.contains("'|u1'") {
        body.iter().map(|&x| x as f32).collect()
    } else {
        assert!(header.contains("'<f4'"), "{header}");
        body.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
    };
    (shape, data)
}

fn import(rel: &str, reset: ImportReset) -> Network {
    let path = fixture(rel);
    let g = Graph::read(&path).unwrap();
    nir::import(&path, &g, &ImportOptions { dt_s: 1e-4, reset }).unwrap().network
}

/// Runs `net` on the fixture input and checks, per layer with neurons, spikes exactly and
/// membranes within 1e-4 against `golden(layer)` = (spike file, membrane file).
fn check(net: &Network, input: &str, golden: &[(usize, String, String)]) {
    let (shape, x) = npy(input);
    let steps = shape[0];
    let (record, trace) = forward_dense_traced(net, &x, steps).unwrap();
    for (layer, spk, v) in golden {
        let (_, want_spk) = npy(spk);
        let (_, want_v) = npy(v);
        let n = net.layers[*layer].op.n_out();
        let mut got = vec![0f32; steps * n];
        for (t, fired) in record.spikes[*layer].iter().enumerate() {
            for &j in fired {
                got[t * n + j as usize] = 1.0;
            }
        }
        let total: f32 = want_spk.iter().sum();
        assert!(total > 0.0, "{spk}: the golden file must have spikes");
        let wrong = got.iter().zip(&want_spk).filter(|(a, b)| a != b).count();
        assert_eq!(wrong, 0, "{spk}: {wrong} of {total} spikes differ");
        let worst = trace.v[*layer].iter().zip(&want_v).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-4, "{v}: membrane off by {worst}");
    }
    // the event-driven engine (stepped) gives the same output spikes
    let engine = Engine::new(net, 100, Mode::Stepped).unwrap();
    let mut st = engine.state(0);
    let n_in = net.n_inputs();
    for t in 0..steps {
        for i in 0..n_in {
            if x[t * n_in + i] != 0.0 {
                engine.push(&mut st, t as i64 * 100, i as u32, x[t * n_in + i]).unwrap();
            }
        }
    }
    engine.finish(&mut st, steps as i64 * 100);
    let last = net.layers.len() - 1;
    let want: u64 = record.spikes[last].iter().map(|s| s.len() as u64).sum();
    assert_eq!(st.output.len() as u64, want, "engine output spikes");
    for &(t_us, j) in &st.output {
        assert!(record.spikes[last][(t_us / 100) as usize].contains(&j));
    }
}

#[test]
fn braille_recurrent_cuba_lif_matches_norse() {
    for (model, reset) in [("bias_zero", ImportReset::ToVReset), ("noBias_subtract", ImportReset::Subtract)] {
        let net = import(&format!("braille/braille_noDelay_{model}.nir"), reset);
        assert!(net.layers[0].recurrent.is_some(), "the recurrent loop is wired into layer 0");
        // the recurrent Affine's bias is kept (snnTorch's importer wires it wrongly)
        assert_eq!(net.layers[0].recurrent_bias.is_some(), model == "bias_zero");
        let d = format!("braille/braille_noDelay_{model}");
        let golden = [
            (0, format!("{d}/norse_hid_spk.npy"), format!("{d}/norse_hid_v.npy")),
            (1, format!("{d}/norse_out_spk.npy"), format!("{d}/norse_out_v.npy")),
        ];
        check(&net, "braille/input_spikes.npy", &golden);
        // the synaptic current too
        let (shape, x) = npy("braille/input_spikes.npy");
        let (_, trace) = forward_dense_traced(&net, &x, shape[0]).unwrap();
        let (_, want_i) = npy(&format!("{d}/norse_hid_i.npy"));
        let worst = trace.i[0].iter().zip(&want_i).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-4, "{model}: current off by {worst}");
    }
}

#[test]
fn conv_and_dense_graphs_match_snntorch_import_and_clean_subtract() {
    for (dir, file, layers) in [("conv", "conv_snn.nir", 3), ("dense", "dense_snn.nir", 2)] {
        // NIR semantics: reset to v_reset (snnTorch's importer and fixed Norse agree)
        let net = import(&format!("{dir}/{file}"), ImportReset::ToVReset);
        let with_neurons: Vec<usize> = (0..net.layers.len()).filter(|&k| net.layers[k].neurons.is_some()).collect();
        assert_eq!(with_neurons.len(), layers);
        let golden = |variant: &str| -> Vec<(usize, String, String)> {
            with_neurons
                .iter()
                .enumerate()
                .map(|(j, &k)| (k, format!("{dir}/{variant}_lif{j}_spk.npy"), format!("{dir}/{variant}_lif{j}_v.npy")))
                .collect()
        };
        check(&net, &format!("{dir}/input_spikes.npy"), &golden("snntorch_import"));
        // the same graph with subtraction: Norse with immediate subtract
        let net = import(&format!("{dir}/{file}"), ImportReset::Subtract);
        check(&net, &format!("{dir}/input_spikes.npy"), &golden("norse_fixed_subtract"));
    }
}

#[test]
fn export_then_import_gives_identical_outputs() {
    let dir = tempfile::tempdir().unwrap();
    for (src, reset) in [
        ("braille/braille_noDelay_bias_zero.nir", ImportReset::ToVReset),
        ("conv/conv_snn.nir", ImportReset::ToVReset),
        ("dense/dense_snn.nir", ImportReset::ToVReset),
    ] {
        let net = import(src, reset);
        let g = nir::export(&net, &ExportOptions::new(1e-4)).unwrap();
        let out = dir.path().join("x.nir");
        g.write(&out, true).unwrap();
        let again = nir::import(&out, &Graph::read(&out).unwrap(), &ImportOptions::default()).unwrap().network;
        for seed in 0..3 {
            let input = random_input(seed, 30, net.n_inputs(), 0.1);
            let a = forward_dense(&net, &input, 30).unwrap();
            let b = forward_dense(&again, &input, 30).unwrap();
            assert_eq!(a.spikes, b.spikes, "{src}");
        }
        // parameters survive within float32 rounding of tau = dt / (1 - beta)
        for (l, m) in net.layers.iter().zip(&again.layers) {
            if let (Some(p), Some(q)) = (l.neurons, m.neurons) {
                assert!((p.beta - q.beta).abs() < 1e-6 && (p.alpha - q.alpha).abs() < 1e-6, "{p:?} {q:?}");
            }
        }
    }
    // subtraction cannot be written without saying so
    let net = import("dense/dense_snn.nir", ImportReset::Subtract);
    let e = nir::export(&net, &ExportOptions::new(1e-4)).unwrap_err().to_string();
    assert!(e.contains("subtraction"), "{e}");
    assert!(
        nir::export(&net, &ExportOptions { subtract: SubtractExport::AsReset, ..ExportOptions::new(1e-4) }).is_ok()
    );
}

/// A parameter of node `name`, all equal across neurons.
fn param(g: &Graph, name: &str, key: &str) -> f64 {
    let a = &g.nodes[name].params[key];
    assert!(a.data.iter().all(|&v| v == a.data[0]), "{name}.{key}");
    a.data[0]
}

#[test]
fn every_convention_reads_back_as_trained_and_fits_its_importer() {
    let dir = tempfile::tempdir().unwrap();
    // the fixtures' decays as a model stepping 10 ms: snnTorch's fixed 100 us step differs
    let dt_s = 0.01;
    for src in ["braille/braille_noDelay_bias_zero.nir", "conv/conv_snn.nir", "dense/dense_snn.nir"] {
        let net = import(src, ImportReset::ToVReset);
        for convention in [Convention::Nir, Convention::Snntorch, Convention::Norse] {
            let g = nir::export(&net, &ExportOptions { convention, ..ExportOptions::new(dt_s) }).unwrap();
            let out = dir.path().join("x.nir");
            g.write(&out, true).unwrap();
            let opts = ImportOptions { dt_s: convention.import_dt_s(dt_s), reset: ImportReset::ToVReset };
            let again = nir::import(&out, &Graph::read(&out).unwrap(), &opts).unwrap().network;
            for seed in 0..3 {
                let input = random_input(seed, 40, net.n_inputs(), 0.1);
                let a = forward_dense(&net, &input, 40).unwrap();
                let b = forward_dense(&again, &input, 40).unwrap();
                assert_eq!(a.spikes, b.spikes, "{src} {convention:?}");
            }
            // what each peer's importer asserts or drops (snntorch/import_nir.py, norse import_nir.py)
            for (name, node) in &g.nodes {
                let dt = opts.dt_s;
                match (node.kind.as_str(), convention) {
                    ("CubaLIF", Convention::Snntorch) => {
                        let (r, tm, ts, w_in) = (
                            param(&g, name, "r"),
                            param(&g, name, "tau_mem"),
                            param(&g, name, "tau_syn"),
                            param(&g, name, "w_in"),
                        );
                        assert!(
                            (r - tm / nir::SNNTORCH_DT_S).abs() <= 1e-5 * r,
                            "r not supported in CubaLIF: {r} {tm}"
                        );
                        assert!((w_in * nir::SNNTORCH_DT_S / ts - 1.0).abs() < 1e-5, "{name}: w_in {w_in}");
                    }
                    ("LIF", Convention::Snntorch) => {
                        assert!(
                            (param(&g, name, "r") * nir::SNNTORCH_DT_S / param(&g, name, "tau") - 1.0).abs() < 1e-5
                        );
                    }
                    ("CubaLIF", Convention::Norse) => {
                        assert_eq!((param(&g, name, "r"), param(&g, name, "w_in")), (1.0, 1.0), "{name}");
                    }
                    ("LIF", Convention::Norse) => assert_eq!(param(&g, name, "r"), 1.0, "{name}"),
                    ("LIF", Convention::Nir) => {
                        assert!((param(&g, name, "r") * dt / param(&g, name, "tau") - 1.0).abs() < 1e-5);
                    }
                    _ => {}
                }
            }
        }
    }
}

#[test]
fn targets_name_the_offending_node_and_rule() {
    let conv = import("conv/conv_snn.nir", ImportReset::ToVReset);
    let e = nir::check_target(&conv, Target::Xylo).unwrap_err().to_string();
    assert!(e.contains("layer 0") && e.contains("node `layer0.op`") && e.contains("no convolution"), "{e}");
    let e = nir::check_target(&conv, Target::Speck).unwrap_err().to_string();
    assert!(e.contains("layer0.neurons") && e.contains("IF neurons"), "{e}");
    nir::check_target(&conv, Target::Generic).unwrap();
    let braille = import("braille/braille_noDelay_bias_zero.nir", ImportReset::ToVReset);
    nir::check_target(&braille, Target::Xylo).unwrap();
    let e = nir::check_target(&braille, Target::Speck).unwrap_err().to_string();
    assert!(e.contains("Speck"), "{e}");
}

#[test]
fn chip_limits_are_the_toolchains_own() {
    use snn::network::{Layer, Op, PoolKind};
    use snn::neuron::NeuronParams;
    let if_ = NeuronParams::integrate_and_fire().with_reset(snn::neuron::Reset::Zero);
    let dense = |n_in: usize, n_out: usize| Op::Dense { n_in, n_out, weight: vec![0.1; n_in * n_out], bias: None };
    let conv = |in_shape: [usize; 3], out: usize, k: [usize; 2], padding: [usize; 2]| Op::Conv2d {
        in_shape,
        out_channels: out,
        kernel: k,
        stride: [1, 1],
        padding,
        weight: vec![0.1; out * in_shape[0] * k[0] * k[1]],
        bias: None,
    };
    let layer = |op: Op, neurons: Option<NeuronParams>| Layer { op, neurons, recurrent: None, recurrent_bias: None };
    // Speck: a small IF convolutional network fits its cores
    let speck = Network::new(
        vec![2, 32, 40],
        vec![
            layer(conv([2, 32, 40], 8, [3, 3], [1, 1]), Some(if_)),
            layer(Op::Pool { kind: PoolKind::Sum, in_shape: [8, 32, 40], kernel: [2, 2], stride: [2, 2] }, None),
            layer(conv([8, 16, 20], 16, [3, 3], [3, 1]), Some(if_)),
            layer(Op::Pool { kind: PoolKind::Sum, in_shape: [16, 20, 20], kernel: [2, 2], stride: [2, 2] }, None),
            layer(dense(1600, 26), Some(if_)),
        ],
    )
    .unwrap();
    nir::check_target(&speck, Target::Speck).unwrap();
    // a dense layer over a non-square map is a non-square kernel
    let flat = Network::new(vec![2, 32, 40], vec![layer(dense(2560, 26), Some(if_))]).unwrap();
    let e = nir::check_target(&flat, Target::Speck).unwrap_err().to_string();
    assert!(e.contains("layer 0") && e.contains("height and width must be equal"), "{e}");
    // a dense 2560 -> 256 IF layer needs more kernel memory than any core has
    let big =
        Network::new(vec![2560], vec![layer(dense(2560, 256), Some(if_)), layer(dense(256, 26), Some(if_))]).unwrap();
    let e = nir::check_target(&big, Target::Speck).unwrap_err().to_string();
    assert!(e.contains("does not fit Speck's cores"), "{e}");
    // Xylo: 16 inputs, 1000 hidden, 8 outputs
    let lif = NeuronParams::lif(0.9).with_reset(snn::neuron::Reset::Zero);
    let xylo = |n_in: usize, hidden: usize, out: usize| {
        Network::new(vec![n_in], vec![layer(dense(n_in, hidden), Some(lif)), layer(dense(hidden, out), Some(lif))])
            .unwrap()
    };
    nir::check_target(&xylo(16, 1000, 8), Target::Xylo).unwrap();
    let e = nir::check_target(&xylo(24, 256, 8), Target::Xylo).unwrap_err().to_string();
    assert!(e.contains("16 input channels"), "{e}");
    let e = nir::check_target(&xylo(12, 1001, 8), Target::Xylo).unwrap_err().to_string();
    assert!(e.contains("layer 0") && e.contains("1000 hidden"), "{e}");
    let e = nir::check_target(&xylo(12, 256, 27), Target::Xylo).unwrap_err().to_string();
    assert!(e.contains("layer 1") && e.contains("8 output neurons"), "{e}");
}

#[test]
fn bad_graphs_are_refused_with_the_file_and_the_node() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.nir");
    std::fs::write(&p, b"not hdf5 at all").unwrap();
    let e = Graph::read(&p).unwrap_err().to_string();
    assert!(e.contains("bad.nir") && e.contains("not a NIR file"), "{e}");
    // an unsupported node on the chain
    let mut g = Graph::read(&fixture("dense/dense_snn.nir")).unwrap();
    g.nodes.get_mut("1").unwrap().kind = "Threshold".into();
    let e = nir::import(&p, &g, &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("bad.nir") && e.contains("node `1`") && e.contains("Threshold"), "{e}");
    // per-neuron time constants that differ
    let mut g = Graph::read(&fixture("dense/dense_snn.nir")).unwrap();
    g.nodes.get_mut("1").unwrap().params.get_mut("tau").unwrap().data[3] = 5e-3;
    let e = nir::import(&p, &g, &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("node `1`") && e.contains("`tau` differs across neurons"), "{e}");
    // a truncated file
    let bytes = std::fs::read(fixture("dense/dense_snn.nir")).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 3]).unwrap();
    let e = Graph::read(&p).unwrap_err().to_string();
    assert!(e.contains("bad.nir"), "{e}");
}

/// Found by the `nir_import` fuzz target: a dataset header claiming about 8 TB. It is refused
/// before anything is allocated, and the file and the dataset are named.
#[test]
fn a_dataset_claiming_terabytes_is_refused() {
    let p = fixture("fuzz_huge_dataset.nir");
    let e = Graph::read(&p).unwrap_err().to_string();
    assert!(e.contains("fuzz_huge_dataset.nir") && e.contains("more than the limit"), "{e}");
}
