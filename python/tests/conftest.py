"""Shared helpers: the repository's fixtures, and the `braille` binary to compare with."""

import os
import pathlib
import shutil

import numpy as np
import pytest

import neurobraille

ROOT = pathlib.Path(__file__).resolve().parents[2]
NIR_FIXTURES = ROOT / "snn" / "tests" / "fixtures" / "nir"


@pytest.fixture(scope="session")
def cli():
    """The `braille` binary: $BRAILLE_BIN (CI sets it, and then it must exist), else a build in
    target/, else skip."""
    given = os.environ.get("BRAILLE_BIN")
    if given:
        assert os.path.exists(given), f"BRAILLE_BIN={given} does not exist"
        return given
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "braille"
        if p.exists():
            return str(p)
    found = shutil.which("braille")
    if found:
        return found
    pytest.skip("no braille binary (cargo build, or set BRAILLE_BIN)")


def python_with(module, python_var, require_var, hint):
    """The Python that has `module` for a vendor check: $`python_var` (CI's environment of its
    own), else this one. Skips when it lacks the module, or fails when $`require_var` is set (CI)."""
    import subprocess
    import sys

    python = os.environ.get(python_var, sys.executable)
    probe = subprocess.run(
        [python, "-c", f"import importlib.util, sys; sys.exit(importlib.util.find_spec({module!r}) is None)"],
        capture_output=True,
    )
    if probe.returncode != 0:
        if os.environ.get(require_var):
            raise RuntimeError(f"{module} is not installed for {python}")
        pytest.skip(f"{module} is not installed ({hint}, or set {python_var})")
    return python


def spikes_to_events(spikes, dt_us, flat_width=None):
    """A golden fixture's input spikes `[T, C, H, W]` (or `[T, n]`) as events of EVENTS_DTYPE:
    step t at t * dt_us, pixel (x, y), polarity = channel; a flat input of n is a row of n/2 taxels
    with OFF and ON, as the engine maps it."""
    spikes = np.asarray(spikes)
    if spikes.ndim == 2:
        t, i = np.nonzero(spikes)
        w = flat_width or spikes.shape[1] // 2
        c, y, x = i // w, np.zeros_like(i), i % w
    else:
        t, c, y, x = np.nonzero(spikes)
    order = np.lexsort((x, y, c, t))
    ev = np.empty(len(t), dtype=neurobraille.EVENTS_DTYPE)
    ev["t"], ev["x"], ev["y"], ev["p"] = t[order] * dt_us, x[order], y[order], c[order]
    return ev
