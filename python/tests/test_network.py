"""Networks from Python: NIR fixtures give snnTorch's spikes and the CLI's, batches equal single
runs, export round-trips, and bad input is named."""

import json
import subprocess

import numpy as np
import pytest

import neurobraille
from conftest import NIR_FIXTURES, ROOT, spikes_to_events

DT_US = 100  # the fixtures' dt = 1e-4 s


def golden_spikes(path):
    """A golden `[T, ...]` spike array as sorted rows (step, flat neuron)."""
    s = np.load(path).reshape(np.load(path).shape[0], -1)
    return np.argwhere(s > 0)


@pytest.mark.parametrize("name,layers", [("conv", 3), ("dense", 2)])
def test_nir_fixture_gives_snntorchs_spikes(name, layers):
    net = neurobraille.Network.load(NIR_FIXTURES / name / f"{name}_snn.nir", dt_us=DT_US)
    assert net.source == "nir_graph"
    spikes = np.load(NIR_FIXTURES / name / "input_spikes.npy")
    rec = net.record(spikes_to_events(spikes, DT_US), steps=spikes.shape[0])
    assert rec["steps"] == spikes.shape[0]
    assert len(rec["spikes"]) == layers
    for j in range(layers):
        want = golden_spikes(NIR_FIXTURES / name / f"snntorch_import_lif{j}_spk.npy")
        np.testing.assert_array_equal(rec["spikes"][j], want, err_msg=f"{name} layer {j}")


@pytest.mark.parametrize("name", ["conv", "dense"])
def test_python_and_cli_agree_on_a_nir_fixture(tmp_path, cli, name):
    graph = NIR_FIXTURES / name / f"{name}_snn.nir"
    spikes = np.load(NIR_FIXTURES / name / "input_spikes.npy")
    events = spikes_to_events(spikes, DT_US)
    path = tmp_path / "in.npy"
    neurobraille.write_events(path, events)
    net = neurobraille.Network.load(graph, dt_us=DT_US)

    # every spike: `braille run` against Network.record
    out = tmp_path / "spikes.csv"
    subprocess.run([cli, "run", "--model", graph, "--events", path, "--dt-us", str(DT_US), "--out", out], check=True)
    rows = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.int64, ndmin=2)
    rec = net.record(events)
    for k, layer in enumerate(rec["spikes"]):
        np.testing.assert_array_equal(rows[rows[:, 0] == k][:, 1:], layer, err_msg=f"layer {k}")

    # the work: `braille bench --model --events --json` against Network.run, both modes that run
    for mode in ["stepped", "async"]:
        bench = subprocess.run(
            [cli, "bench", "--model", graph, "--events", path, "--dt-us", str(DT_US), "--mode", mode, "--json"],
            capture_output=True,
            text=True,
        )
        try:
            r = net.run(events, mode=mode, t_start_us=int(events["t"][0]))
        except neurobraille.BrailleError as e:
            assert bench.returncode != 0, f"Python refused {mode} but the CLI ran it: {e}"
            assert "async mode runs" in str(e)
            continue
        assert bench.returncode == 0, bench.stderr
        report = json.loads(bench.stdout)
        assert report["samples"] == 1
        assert r.input_events == len(events)
        assert r.synops == report["synops_per_sample"]
        # the bench counts every layer, Python the layers with neurons (as `record` lists them)
        assert r.spikes_per_layer == [report["spikes_per_layer_per_sample"][k] for k in rec["layers"]]


def test_batch_equals_single_runs_and_threads_share_the_network():
    net, samples = neurobraille.peer_benchmark(6)
    assert net.input_shape == [2, 60, 80] and net.dt_us == 1000 and net.readout == "spike-count"
    single = [net.run(s, t_end_us=20_000) for s in samples]
    batch = net.run_batch(samples, t_end_us=20_000)
    for a, b in zip(single, batch):
        np.testing.assert_array_equal(a.readout, b.readout)
        assert (a.synops, a.spikes_per_layer, a.prediction) == (b.synops, b.spikes_per_layer, b.prediction)
        np.testing.assert_array_equal(a.output_spikes, b.output_spikes)
    # the same network and samples give the same results again
    again = net.run(samples[0], t_end_us=20_000, latency=True)
    np.testing.assert_array_equal(again.readout, single[0].readout)
    assert again.latency_ns is not None and len(again.latency_ns) == again.input_events
    assert single[0].latency_ns is None
    # the output spikes are the readout's counts
    counts = np.bincount(single[0].output_spikes[:, 1], minlength=net.n_outputs)
    np.testing.assert_array_equal(counts, single[0].readout)


def test_model_file_exports_to_nir_and_reloads_the_same(tmp_path):
    model = ROOT / "models" / "icub" / "nir" / "snn-th10.safetensors"
    net = neurobraille.Network.load(model)
    assert net.source == "model_file" and net.readout == "max-membrane"
    out = tmp_path / "th10.nir"
    dt_s = net.export(out, target="loihi2")
    assert dt_s == pytest.approx(net.dt_us * 1e-6)
    back = neurobraille.Network.load(out, dt_us=net.dt_us)
    rng = np.random.default_rng(0)
    n = 400
    ev = np.empty(n, dtype=neurobraille.EVENTS_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 100 * net.dt_us, n))
    ev["x"], ev["y"], ev["p"] = rng.integers(0, net.n_inputs // 2, n), 0, rng.integers(0, 2, n)
    a, b = net.run(ev), back.run(ev)
    np.testing.assert_allclose(a.readout, b.readout, rtol=1e-5, atol=1e-5)
    assert a.spikes_per_layer == b.spikes_per_layer
    with pytest.raises(FileExistsError):
        net.export(out)


def test_chip_rules_and_bad_input_are_named(tmp_path):
    net = neurobraille.Network.load(ROOT / "models" / "icub" / "nir" / "snn-th10.safetensors")
    with pytest.raises(neurobraille.BrailleError, match="xylo|Xylo"):
        net.check("xylo")
    with pytest.raises(ValueError, match="one of generic"):
        net.check("tpu")
    shipped = neurobraille.Network.load(ROOT / "models" / "icub" / "snn-th10.safetensors")
    with pytest.raises(neurobraille.BrailleError, match="subtraction"):
        shipped.export(tmp_path / "x.nir")
    garbage = tmp_path / "garbage.safetensors"
    garbage.write_bytes(b"not a model at all")
    with pytest.raises(neurobraille.BrailleError, match="garbage.safetensors"):
        neurobraille.Network.load(garbage)
    with pytest.raises(FileNotFoundError, match="nothing.nir"):
        neurobraille.Network.load(tmp_path / "nothing.nir")
    ev = np.zeros(2, dtype=neurobraille.EVENTS_DTYPE)
    ev["x"][1] = 5000
    with pytest.raises(neurobraille.BrailleError, match=r"event 1 .*outside the network's input"):
        net.run(ev)
    with pytest.raises(ValueError, match="mode"):
        net.run(ev[:1], mode="sometimes")


def test_python_runs_the_xylo_model_in_xylos_arithmetic_as_the_cli(tmp_path, cli):
    """Network.run(chip="xylo") on the events of each raw1350 test sample (rebuilt from the CLI's
    trace: its input counts per step) gives the CLI's readout, prediction and hidden spikes."""
    model = ROOT / "models" / "icub" / "chip" / "xylo-braille7.safetensors"
    trace_path = tmp_path / "trace.json"
    subprocess.run(
        [cli, "eval", "--data", str(ROOT / "data" / "icub_braille" / "raw1350"), "--model", str(model),
         "--split", "test", "--chip", "xylo", "--trace", str(trace_path), "--json"],
        check=True, capture_output=True,
    )
    trace = json.loads(trace_path.read_text())
    net = neurobraille.Network.load(model)
    dt = net.dt_us
    taxels = net.n_inputs // 2
    for s in trace["samples"][:12]:
        x = np.array(s["input"])
        rows = [(k * dt + 10, i) for k, i in zip(*np.nonzero(x)) for _ in range(x[k, i])]
        ev = np.zeros(len(rows), dtype=neurobraille.EVENTS_DTYPE)
        ev["t"] = [t for t, _ in rows]
        ev["x"] = [i % taxels for _, i in rows]
        ev["p"] = [i // taxels for _, i in rows]
        for mode in ["stepped", "event-driven"]:
            r = net.run(ev, mode=mode, chip="xylo", t_start_us=0, t_end_us=len(x) * dt)
            v_max = np.maximum(np.array(s["v_mem_out"]).max(axis=0), 0)
            np.testing.assert_array_equal(r.readout, v_max)
            assert r.prediction == s["predicted"]
            assert r.spikes_per_layer[0] == sum(n for _, _, n in s["hidden_spikes"])
    with pytest.raises(ValueError, match="quantisation"):
        net.run(ev, chip="xylo", quantisation="none")
    with pytest.raises(ValueError, match="chip"):
        net.run(ev, chip="loihi")


def test_python_runs_the_speck_model_in_specks_arithmetic_as_the_cli(tmp_path, cli):
    """Network.run(chip="speck") on the events of simulated character windows (rebuilt from the
    CLI's trace: its input counts per step) gives the CLI's output counts and prediction."""
    model = ROOT / "models" / "nominal" / "chip" / "speck-chars.safetensors"
    trace_path = tmp_path / "trace.json"
    subprocess.run(
        [cli, "eval", "chars", "--arch", "snn", "--model", str(model), "--realism", "nominal", "--trials", "1",
         "--chip", "speck", "--trace", str(trace_path), "--json"],
        check=True, capture_output=True,
    )
    trace = json.loads(trace_path.read_text())
    c, h, w = trace["spec"]["cores"][0]["in_shape"]
    net = neurobraille.Network.load(model)
    dt = net.dt_us
    for s in trace["samples"][:6]:
        rows = [(t * dt + 10, ch) for t, ch, n in s["input"] for _ in range(n)]
        ev = np.zeros(len(rows), dtype=neurobraille.EVENTS_DTYPE)
        ev["t"] = [t for t, _ in rows]
        ev["x"] = [ch % w for _, ch in rows]
        ev["y"] = [(ch // w) % h for _, ch in rows]
        ev["p"] = [ch // (h * w) for _, ch in rows]
        for mode in ["stepped", "event-driven"]:
            r = net.run(ev, mode=mode, chip="speck", t_start_us=0, t_end_us=s["steps"] * dt)
            np.testing.assert_array_equal(r.readout, s["out_counts"])
            assert r.prediction == s["predicted"]
            # each core's spikes, the last core's being the output
            per_core = [sum(n for _, c, _, n in s["spikes"] if c == k) for k in range(3)]
            assert list(r.spikes_per_layer) == per_core
            assert per_core[-1] == sum(s["out_counts"])
    with pytest.raises(neurobraille.BrailleError, match="one threshold"):
        net.run(ev, chip="speck", quantisation="channel")


def test_python_runs_a_model_in_loihi_2s_arithmetic_as_the_cli(tmp_path, cli):
    """Network.run(chip="loihi2") on the events of raw1350 validation samples (rebuilt from the
    CLI's trace) gives the CLI's membranes, prediction and spikes, the latency's drain steps
    included."""
    model = ROOT / "models" / "icub" / "nir" / "snn-raw1350.safetensors"
    trace_path = tmp_path / "trace.json"
    subprocess.run(
        [cli, "eval", "--data", str(ROOT / "data" / "icub_braille" / "raw1350"), "--model", str(model),
         "--split", "validation", "--val-seed", "2", "--chip", "loihi2", "--trace", str(trace_path), "--json"],
        check=True, capture_output=True,
    )
    trace = json.loads(trace_path.read_text())
    layers = len(trace["spec"]["layers"])
    net = neurobraille.Network.load(model)
    dt = net.dt_us
    taxels = net.n_inputs // 2
    for s in trace["samples"][:8]:
        rows = [(t * dt + 10, ch) for t, ch, n in s["input"] for _ in range(n)]
        ev = np.zeros(len(rows), dtype=neurobraille.EVENTS_DTYPE)
        ev["t"] = [t for t, _ in rows]
        ev["x"] = [ch % taxels for _, ch in rows]
        ev["p"] = [ch // taxels for _, ch in rows]
        for mode in ["stepped", "event-driven"]:
            r = net.run(ev, mode=mode, chip="loihi2", t_start_us=0, t_end_us=(s["steps"] - layers) * dt)
            np.testing.assert_array_equal(r.readout, np.array(s["v_out"]).max(axis=0))
            assert r.prediction == s["predicted"]
            per_layer = [sum(1 for _, k, _ in s["spikes"] if k == layer) for layer in range(layers)]
            assert list(r.spikes_per_layer) == per_layer and per_layer[0] > 0
    with pytest.raises(neurobraille.BrailleError, match="one weight exponent"):
        net.run(ev, chip="loihi2", quantisation="channel")
