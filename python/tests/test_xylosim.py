"""The engine's Xylo arithmetic against SynSense's own simulator (PyPI `xylosim`, the C++
simulator Rockpool's XyloSim runs): the shipped Xylo model on the iCub raw1350 test split, every
hidden spike and every output membrane of every step (scripts/chips/xylosim_check.py).

CI installs xylosim and sets BRAILLE_REQUIRE_XYLOSIM=1, so there a missing simulator fails."""

import json
import os
import subprocess
import sys

import pytest

from conftest import ROOT

MODEL = ROOT / "models" / "icub" / "chip" / "xylo-braille7.safetensors"
DATA = ROOT / "data" / "icub_braille" / "raw1350"
CHECK = ROOT / "scripts" / "chips" / "xylosim_check.py"


def _need_xylosim():
    try:
        import xylosim.v2  # noqa: F401
    except ImportError:
        if os.environ.get("BRAILLE_REQUIRE_XYLOSIM"):
            raise
        pytest.skip("xylosim is not installed (pip install xylosim)")


@pytest.mark.parametrize("quantisation,run", [("global", "event-driven"), ("channel", "stepped")])
def test_xylo_model_runs_spike_for_spike_as_xylosim(tmp_path, cli, quantisation, run):
    _need_xylosim()
    trace = tmp_path / "trace.json"
    out = subprocess.run(
        [cli, "eval", "--data", str(DATA), "--model", str(MODEL), "--split", "test", "--chip", "xylo",
         "--quantisation", quantisation, "--chip-run", run, "--trace", str(trace), "--json"],
        check=True, capture_output=True, text=True,
    )
    report = json.loads(out.stdout)
    assert report["n"] == 70 and report["chip"]["chip"] == "xylo"
    check = subprocess.run([sys.executable, str(CHECK), str(trace)], capture_output=True, text=True)
    summary = json.loads(check.stdout)
    assert check.returncode == 0, summary
    assert summary["samples"] == 70 and summary["samples_differing"] == 0
    # the check is not vacuous: the hidden layer spikes, and every prediction is the simulator's
    assert summary["hidden_spikes_xylosim"] > 100_000
    assert summary["hidden_spikes_engine"] == summary["hidden_spikes_xylosim"]
    assert summary["predictions_agreeing"] == 70
    # the trace's predictions are the scored ones
    correct = sum(s["predicted"] == s["label"] for s in json.loads(trace.read_text())["samples"])
    assert correct == report["correct"]


def test_a_changed_decay_is_caught(tmp_path, cli):
    """The check fails when the specification differs from what the engine ran."""
    _need_xylosim()
    trace = tmp_path / "trace.json"
    subprocess.run(
        [cli, "eval", "--data", str(DATA), "--model", str(MODEL), "--split", "test", "--chip", "xylo",
         "--trace", str(trace), "--json"],
        check=True, capture_output=True,
    )
    t = json.loads(trace.read_text())
    t["spec"]["dash_syn"] = [d + 1 for d in t["spec"]["dash_syn"]]
    trace.write_text(json.dumps(t))
    check = subprocess.run([sys.executable, str(CHECK), str(trace)], capture_output=True, text=True)
    assert check.returncode == 1
    assert json.loads(check.stdout)["samples_differing"] > 0
