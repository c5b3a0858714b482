#!/usr/bin/env python3
"""Spike-for-spike check of the engine's Speck arithmetic against SynSense's Sinabs.

Reads a trace from `braille eval chars --chip speck --trace TRACE.json` (or `braille eval --chip
speck`): the model mapped to Speck's formats (its cores: integer weights, thresholds, reset,
pooling), the float weights it was quantised from, and every sample as the engine ran it. Then,
with PyPI `sinabs` (3.1.3):

1. the quantiser: each core's float convolution and IF layer through Sinabs's own
   `discretize_conv_spike_` (`sinabs/backend/dynapcnn/discretize.py`), with `min_v_mem` at the
   16-bit floor in the core's scale, must give the trace's integer weights and threshold;
2. the arithmetic: each core built from Sinabs's layers as `DynapcnnLayer` holds them
   (`nn.Conv2d` without bias, a dense core as a convolution over its whole input as Sinabs's
   `_convert_linear_to_conv` makes it, `sinabs.layers.IAF` with `MultiSpike`, `MembraneReset` or
   `MembraneSubtract` and `min_v_mem`, `sinabs.layers.SumPool2d`), every sample run through them
   time step by time step as Sinabs runs a network, and every core's spikes at every step compared
   with the engine's.

Prints a JSON summary; exits 1 on any difference.

    python3 scripts/chips/sinabs_check.py TRACE.json

Sinabs imports samna, SynSense's hardware driver, at import time (for its chip I/O); samna's PyPI
entry is a placeholder that, when imported, installs the driver from SynSense's GitLab, out of
reach here. None of samna's code runs in this check, so an empty stand-in module takes its place.
"""

import importlib.abc
import importlib.machinery
import json
import sys
import types


class _Anything(type):
    """A class whose attributes are itself: what sinabs's module-level uses of samna need."""

    def __getattr__(cls, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return cls

    def __getitem__(cls, item):
        return cls


class _Stand(metaclass=_Anything):
    def __init__(self, *args, **kwargs):
        pass


class _StandInModule(types.ModuleType):
    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return _Stand


class _StandInFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Stands in for `samna` and `samnagui` (and their submodules) only."""

    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in ("samna", "samnagui"):
            return importlib.machinery.ModuleSpec(name, self, is_package=True)
        return None

    def create_module(self, spec):
        m = _StandInModule(spec.name)
        m.__path__ = []
        return m

    def exec_module(self, module):
        pass


def _import_sinabs():
    # always the stand-in: PyPI's `samna` (a dependency of sinabs) is a placeholder that, when
    # imported, tries to install the real driver from SynSense's GitLab
    sys.meta_path.insert(0, _StandInFinder())
    import sinabs
    import sinabs.activation as sa
    import sinabs.layers as sl
    from sinabs.backend.dynapcnn.discretize import determine_discretization_scale, discretize_conv_spike_

    return sinabs, sa, sl, determine_discretization_scale, discretize_conv_spike_


def core_modules(core, torch, nn, sa, sl, float_weights=None, float_threshold=None, min_v_mem=None):
    """A core as Sinabs's layers: convolution, IF neurons, optional sum pooling."""
    c, h, w = core["in_shape"]
    op = core["op"]
    if "Conv" in op:
        p = op["Conv"]
        conv = nn.Conv2d(c, p["out_channels"], tuple(p["kernel"]), stride=tuple(p["stride"]),
                         padding=tuple(p["padding"]), bias=False)
        shape = (p["out_channels"], c, p["kernel"][0], p["kernel"][1])
    else:
        n_out = op["Dense"]["n_out"]
        conv = nn.Conv2d(c, n_out, (h, w), bias=False)
        shape = (n_out, c, h, w)
    weights = float_weights if float_weights is not None else core["weights"]
    with torch.no_grad():
        conv.weight.copy_(torch.tensor(weights, dtype=torch.float32).reshape(shape))
    reset = sa.MembraneReset() if core["return_to_zero"] else sa.MembraneSubtract()
    iaf = sl.IAF(
        spike_threshold=torch.tensor(float(float_threshold if float_threshold is not None else core["threshold"])),
        spike_fn=sa.MultiSpike,
        reset_fn=reset,
        min_v_mem=float(min_v_mem if min_v_mem is not None else core["threshold_low"]),
    )
    pool = sl.SumPool2d(core["pool"]) if core["pool"] > 1 else None
    return conv, iaf, pool


def check_quantiser(trace, torch, nn, sa, sl, scale_of, discretize):
    """Sinabs's discretisation of the float cores against the trace's integers."""
    differing = []
    for k, (core, fl) in enumerate(zip(trace["spec"]["cores"], trace["float"])):
        w = torch.tensor(fl["weights"], dtype=torch.float32)
        scale_w = scale_of(w, 8)
        conv, iaf, _ = core_modules(core, torch, nn, sa, sl, fl["weights"], fl["threshold"],
                                    min_v_mem=-(2 ** 15) / float(scale_w))
        conv_q, iaf_q = discretize(conv, iaf, to_int=True)
        ours = torch.tensor(core["weights"], dtype=torch.float32).reshape(conv_q.weight.shape)
        if not torch.equal(conv_q.weight.detach(), ours) or int(iaf_q.spike_threshold) != core["threshold"]:
            differing.append({
                "core": k,
                "weights_differing": int((conv_q.weight.detach() != ours).sum()),
                "threshold_sinabs": int(iaf_q.spike_threshold),
                "threshold_engine": core["threshold"],
            })
    return differing


def main(path):
    with open(path) as f:
        trace = json.load(f)
    if trace.get("chip") != "speck":
        print(json.dumps({"trace": path, "error": "not a Speck trace"}))
        return 1
    sinabs, sa, sl, scale_of, discretize = _import_sinabs()
    import numpy as np
    import torch
    import torch.nn as nn

    torch.set_grad_enabled(False)
    cores = trace["spec"]["cores"]
    modules = [core_modules(core, torch, nn, sa, sl) for core in cores]
    c0, h0, w0 = cores[0]["in_shape"]
    quantiser = check_quantiser(trace, torch, nn, sa, sl, scale_of, discretize)
    differing, first, spikes_ours, spikes_theirs, steps, agree = 0, None, 0, 0, 0, 0
    for k, s in enumerate(trace["samples"]):
        t_n = s["steps"]
        steps += t_n
        x = torch.zeros((t_n, c0 * h0 * w0), dtype=torch.float32)
        for t, ch, n in s["input"]:
            x[t, ch] = n
        x = x.reshape(t_n, c0, h0, w0)
        ours = []
        theirs = []
        for (conv, iaf, pool), core in zip(modules, cores):
            iaf.reset_states()
            c, h, w = core["in_shape"]
            y = conv(x.reshape(t_n, c, h, w))  # every step at once: the convolution has no state
            z = iaf(y.unsqueeze(0)).squeeze(0)  # (batch 1, time, ...): the neurons step through time
            theirs.append(z.reshape(t_n, -1).to(torch.int64).numpy())
            ours.append(np.zeros_like(theirs[-1]))
            x = pool(z) if pool is not None else z
        for t, core, j, n in s["spikes"]:
            ours[core][t, j] = n
        same = all(np.array_equal(a, b) for a, b in zip(ours, theirs))
        spikes_ours += int(sum(a.sum() for a in ours))
        spikes_theirs += int(sum(b.sum() for b in theirs))
        counts = x.reshape(t_n, -1).sum(dim=0).to(torch.int64).numpy()
        pred = int(np.argmax(counts))
        agree += pred == s["predicted"] and counts.tolist() == s["out_counts"]
        if not same:
            differing += 1
            if first is None:
                for ci, (a, b) in enumerate(zip(ours, theirs)):
                    bad = np.argwhere((a != b).any(axis=1))
                    if len(bad):
                        first = {"sample": k, "core": ci, "step": int(bad[0][0])}
                        break
    summary = {
        "trace": path,
        "model": trace["model"],
        "data": trace["data"],
        "sinabs": sinabs.__version__,
        "samples": len(trace["samples"]),
        "steps": steps,
        "spikes_engine": spikes_ours,
        "spikes_sinabs": spikes_theirs,
        "samples_differing": differing,
        "first_difference": first,
        "predictions_agreeing": agree,
        "quantiser_cores_differing": quantiser,
    }
    print(json.dumps(summary, indent=2))
    return 0 if differing == 0 and not quantiser else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
