"""The engine's Speck arithmetic against SynSense's Sinabs (PyPI `sinabs`): the shipped Speck
character model on simulated windows, Sinabs's own quantiser on its float weights and Sinabs's
layers run step by step on the same windows, every spike of every core compared
(scripts/chips/sinabs_check.py).

CI installs sinabs in an environment of its own (BRAILLE_SINABS_PYTHON) and sets
BRAILLE_REQUIRE_SINABS=1, so there a missing Sinabs fails."""

import json
import subprocess

import pytest

from conftest import ROOT, python_with

MODEL = ROOT / "models" / "nominal" / "chip" / "speck-chars.safetensors"
CHECK = ROOT / "scripts" / "chips" / "sinabs_check.py"


def _sinabs_python():
    """The Python that has sinabs (CI's own environment: sinabs pins an older `nir` than the
    interop tests use)."""
    return python_with("sinabs", "BRAILLE_SINABS_PYTHON", "BRAILLE_REQUIRE_SINABS", "pip install sinabs")


@pytest.fixture(scope="module")
def speck_trace(tmp_path_factory, cli):
    _sinabs_python()
    trace = tmp_path_factory.mktemp("speck") / "trace.json"
    out = subprocess.run(
        [cli, "eval", "chars", "--arch", "snn", "--model", str(MODEL), "--realism", "nominal",
         "--trials", "1", "--chip", "speck", "--chip-run", "stepped", "--trace", str(trace), "--json"],
        check=True, capture_output=True, text=True,
    )
    return trace, json.loads(out.stdout)


def _check(path):
    run = subprocess.run([_sinabs_python(), str(CHECK), str(path)], capture_output=True, text=True)
    return run.returncode, json.loads(run.stdout)


def test_speck_model_runs_spike_for_spike_as_sinabs(speck_trace):
    trace, report = speck_trace
    assert report["chip"]["chip"] == "speck" and report["n"] == 26
    code, summary = _check(trace)
    assert code == 0, summary
    assert summary["samples"] == 26 and summary["samples_differing"] == 0
    assert summary["quantiser_cores_differing"] == []
    # not vacuous: every core spikes, and every prediction and output count is Sinabs's
    assert summary["spikes_sinabs"] > 100_000
    assert summary["spikes_engine"] == summary["spikes_sinabs"]
    assert summary["predictions_agreeing"] == 26
    samples = json.loads(trace.read_text())["samples"]
    assert {c for s in samples for _, c, _, _ in s["spikes"]} == {0, 1, 2}
    # the trace's predictions are the scored ones
    correct = sum(s["predicted"] == s["label"] for s in samples)
    assert correct == round(report["accuracy"] * report["n"])


def test_a_changed_threshold_or_reset_is_caught(speck_trace, tmp_path):
    """The check fails when the specification differs from what the engine ran."""
    trace, _ = speck_trace
    t = json.loads(trace.read_text())
    t["spec"]["cores"][1]["threshold"] += 1
    bad = tmp_path / "threshold.json"
    bad.write_text(json.dumps(t))
    code, summary = _check(bad)
    assert code == 1 and summary["samples_differing"] > 0
    assert summary["quantiser_cores_differing"][0]["core"] == 1
    t = json.loads(trace.read_text())
    t["spec"]["cores"][0]["return_to_zero"] = not t["spec"]["cores"][0]["return_to_zero"]
    bad = tmp_path / "reset.json"
    bad.write_text(json.dumps(t))
    code, summary = _check(bad)
    assert code == 1 and summary["samples_differing"] > 0
