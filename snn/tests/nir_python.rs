//! Every exported NIR file loads in the reference reader, PyPI `nir` 1.0.8 (`nir.read`, with its
//! type checks), with the parameters the project wrote. Needs Python with `nir`; `.ci/run`
//! installs it. Without it the test is skipped, except under CI (`CI` set), where it fails.

use snn::network::{Layer, Network, Op, PoolKind};
use snn::neuron::{NeuronParams, Reset};
use snn::nir::{self, ExportOptions, Graph, ImportOptions, ImportReset};
use std::path::Path;
use std::process::Command;

const READER: &str = r#"
import json, sys, nir, numpy as np
out = {}
for path in sys.argv[1:]:
    g = nir.read(path)
    nodes = {}
    for name, n in g.nodes.items():
        params = {}
        for k, v in n.__dict__.items():
            if k in ("input_type", "output_type", "metadata"):
                continue
            a = np.asarray(v)
            if a.dtype.kind in "fiu":
                params[k] = [float(x) for x in a.ravel()]
        nodes[name] = {"kind": type(n).__name__, "params": params}
    out[path] = {"nodes": nodes, "edges": sorted([list(e) for e in g.edges])}
print(json.dumps(out))
"#;

fn mixed_network() -> Network {
    let w = |n: usize, s: f32| (0..n).map(|i| ((i * 37 % 11) as f32 - 5.0) * s).collect::<Vec<f32>>();
    let mut cuba = NeuronParams::cuba_lif(0.8, 0.9);
    cuba.v_th = 0.7;
    Network::new(
        vec![2, 8, 8],
        vec![
            Layer {
                op: Op::Conv2d {
                    in_shape: [2, 8, 8],
                    out_channels: 3,
                    kernel: [3, 3],
                    stride: [1, 1],
                    padding: [1, 1],
                    weight: w(54, 0.1),
                    bias: Some(vec![0.1, 0.0, -0.1]),
                },
                neurons: Some(NeuronParams::integrate_and_fire()),
                recurrent: None,
                recurrent_bias: None,
            },
            Layer {
                op: Op::Pool { kind: PoolKind::Sum, in_shape: [3, 8, 8], kernel: [2, 2], stride: [2, 2] },
                neurons: None,
                recurrent: None,
                recurrent_bias: None,
            },
            Layer {
                op: Op::Dense { n_in: 48, n_out: 6, weight: w(288, 0.05), bias: None },
                neurons: Some(cuba.with_reset(Reset::Zero)),
                recurrent: Some(w(36, 0.02)),
                recurrent_bias: Some(vec![0.01; 6]),
            },
            Layer {
                op: Op::Dense { n_in: 6, n_out: 4, weight: w(24, 0.1), bias: Some(vec![0.0; 4]) },
                neurons: Some(NeuronParams::leaky_integrator(0.95)),
                recurrent: None,
                recurrent_bias: None,
            },
        ],
    )
    .unwrap()
}

#[test]
fn pypi_nir_reads_every_exported_file() {
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let available = Command::new(&python).args(["-c", "import nir, numpy"]).output().is_ok_and(|o| o.status.success());
    if !available {
        assert!(std::env::var_os("CI").is_none(), "CI must have python3 with nir (pip install nir==1.0.8)");
        eprintln!("skipped: {python} with nir not found");
        return;
    }
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nir");
    let dir = tempfile::tempdir().unwrap();
    let mut graphs = Vec::new();
    for (i, src) in
        ["braille/braille_noDelay_bias_zero.nir", "conv/conv_snn.nir", "dense/dense_snn.nir"].iter().enumerate()
    {
        let p = fixtures.join(src);
        let net =
            nir::import(&p, &Graph::read(&p).unwrap(), &ImportOptions { dt_s: 1e-4, reset: ImportReset::ToVReset })
                .unwrap()
                .network;
        graphs.push((dir.path().join(format!("g{i}.nir")), nir::export(&net, &ExportOptions::new(1e-4)).unwrap()));
    }
    graphs.push((dir.path().join("mixed.nir"), nir::export(&mixed_network(), &ExportOptions::new(1e-3)).unwrap()));
    for (p, g) in &graphs {
        g.write(p, false).unwrap();
    }
    let o = Command::new(&python)
        .args(["-c", READER])
        .args(graphs.iter().map(|(p, _)| p.to_str().unwrap().to_string()))
        .output()
        .unwrap();
    assert!(o.status.success(), "nir.read failed: {}", String::from_utf8_lossy(&o.stderr));
    let read: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for (p, g) in &graphs {
        let r = &read[p.to_str().unwrap()];
        let mut edges: Vec<Vec<String>> = g.edges.iter().map(|(a, b)| vec![a.clone(), b.clone()]).collect();
        edges.sort();
        assert_eq!(r["edges"], serde_json::json!(edges), "{}", p.display());
        for (name, node) in &g.nodes {
            let rn = &r["nodes"][name];
            assert_eq!(rn["kind"], node.kind, "{name}");
            for (k, a) in &node.params {
                if matches!(k.as_str(), "shape" | "input_type") {
                    continue;
                }
                let got: Vec<f64> = rn["params"][k]
                    .as_array()
                    .unwrap_or_else(|| panic!("{}: node {name} lacks `{k}` in nir.read", p.display()))
                    .iter()
                    .map(|v| v.as_f64().unwrap())
                    .collect();
                assert_eq!(got.len(), a.data.len(), "{name}.{k}");
                for (x, y) in got.iter().zip(&a.data) {
                    // written as float32
                    assert!((x - y).abs() <= 1e-6 * (1.0 + y.abs()), "{name}.{k}: {x} vs {y}");
                }
            }
        }
    }
}
