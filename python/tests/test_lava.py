"""The engine's Loihi 2 arithmetic against Intel's Lava (PyPI `lava-nc` 0.10.0, its bit-accurate
`PyLifModelBitAcc` and `PyDenseModelBitAcc`): a real tactile model with a recurrent, biased
CubaLIF layer, and the convolutional character model with sum pooling, run through Lava's own
processes step by step, every spike of every layer and every output membrane compared
(scripts/chips/lava_check.py).

Lava needs Python 3.10. CI builds it an environment of its own where a Python 3.10 exists
(BRAILLE_LAVA_PYTHON) and sets BRAILLE_REQUIRE_LAVA=1 there, so a missing Lava then fails."""

import json
import subprocess

import pytest

from conftest import ROOT, python_with

CHECK = ROOT / "scripts" / "chips" / "lava_check.py"


def _lava_python():
    return python_with("lava", "BRAILLE_LAVA_PYTHON", "BRAILLE_REQUIRE_LAVA", "Python 3.10: pip install lava-nc")


def _check(path, samples):
    run = subprocess.run(
        [_lava_python(), str(CHECK), str(path), "--samples", str(samples)], capture_output=True, text=True
    )
    assert run.stdout, run.stderr
    return run.returncode, json.loads(run.stdout)


@pytest.fixture(scope="module")
def th10_trace(tmp_path_factory, cli):
    _lava_python()
    trace = tmp_path_factory.mktemp("loihi2") / "th10.json"
    out = subprocess.run(
        [cli, "eval", "--data", str(ROOT / "data" / "icub_braille" / "th10"),
         "--model", str(ROOT / "models" / "icub" / "nir" / "snn-th10.safetensors"),
         "--split", "validation", "--val-seed", "2", "--chip", "loihi2", "--chip-run", "event-driven",
         "--trace", str(trace), "--json"],
        check=True, capture_output=True, text=True,
    )
    return trace, json.loads(out.stdout)


def test_recurrent_biased_model_runs_spike_for_spike_as_lava(th10_trace):
    trace, report = th10_trace
    assert report["chip"]["chip"] == "loihi2"
    code, summary = _check(trace, 6)
    assert code == 0, summary
    assert summary["samples"] == 6 and summary["identical"] == 6
    # not vacuous: the recurrent layer and the bias are there, and the hidden layer spikes
    t = json.loads(trace.read_text())
    assert t["spec"]["layers"][0]["recurrent"] is not None and t["spec"]["layers"][0]["bias_mant"]
    assert summary["spikes"] > 1000
    assert {layer for s in t["samples"][:6] for _, layer, _ in s["spikes"]} >= {0}


def test_conv_pool_character_model_runs_spike_for_spike_as_lava(tmp_path, cli):
    _lava_python()
    trace = tmp_path / "chars.json"
    subprocess.run(
        [cli, "eval", "chars", "--arch", "snn",
         "--model", str(ROOT / "models" / "nominal" / "chip" / "speck-chars.safetensors"),
         "--realism", "nominal", "--board", "VAL", "--sensor-builds", "training", "--trials", "1",
         "--chip", "loihi2", "--trace", str(trace), "--json"],
        check=True, capture_output=True, text=True,
    )
    code, summary = _check(trace, 2)
    assert code == 0, summary
    assert summary["identical"] == 2 and summary["spikes"] > 10_000
    layers = json.loads(trace.read_text())["spec"]["layers"]
    assert [layer["pool"] for layer in layers] == [1, 2, 2]


def test_a_changed_threshold_or_decay_is_caught(th10_trace, tmp_path):
    """The check fails when the specification differs from what the engine ran."""
    trace, _ = th10_trace
    for field, change in [("vth", 1), ("du", 1)]:
        t = json.loads(trace.read_text())
        t["spec"]["layers"][0][field] += change
        bad = tmp_path / f"{field}.json"
        bad.write_text(json.dumps(t))
        code, summary = _check(bad, 2)
        assert code == 1 and summary["identical"] < 2, (field, summary)
