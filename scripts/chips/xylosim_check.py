#!/usr/bin/env python3
"""Spike-for-spike check of the engine's Xylo arithmetic against SynSense's own simulator.

Reads a trace from `braille eval --chip xylo --trace TRACE.json` (the model mapped to Xylo's
formats, and every sample of a split as the engine ran it), builds Rockpool's XyloSim for Xylo
Audio 2 (`rockpool.devices.xylo.syns61201.XyloSim`, running PyPI `xylosim`'s v2 C++ simulator)
from that specification, runs every sample and compares, step by step, every hidden neuron's
spikes and every output neuron's membrane. Prints a JSON summary; exits 1 on any difference.

    python3 scripts/chips/xylosim_check.py TRACE.json

Rockpool's `XyloSim` class cannot be imported without samna, SynSense's hardware driver (its PyPI
entry installs from SynSense's GitLab, out of reach here), so this builds xylosim's `XyloLayer`
(v2, Xylo Audio 2) exactly as Rockpool's `XyloSim.from_config` does
(`rockpool/devices/xylo/syns61201/xylo_sim.py`): one `XyloSynapse(post, 0, weight)` per non-zero
weight, per pre-synaptic neuron; no aliases, no biases.
"""

import json
import sys

import numpy as np
from xylosim.v2 import XyloLayer, XyloSynapse


def synapses(w):
    """Rockpool's conversion: per pre-synaptic row, a synapse to every non-zero target."""
    return [[XyloSynapse(int(post), 0, int(row[post])) for post in np.where(row)[0]] for row in w]


def layer_of(spec):
    n_in, n_h, n_out = spec["n_in"], spec["n_hidden"], spec["n_out"]
    w_in = np.array(spec["weights_in"], dtype=np.int64).reshape(n_in, n_h)
    w_rec = np.array(spec["weights_rec"], dtype=np.int64).reshape(n_h, n_h)
    w_out = np.array(spec["weights_out"], dtype=np.int64).reshape(n_h, n_out)
    # XyloLayer keeps pointers to the synapses: they must outlive it (Rockpool keeps them on the
    # module as `_xylo_sim_params`)
    kept = (synapses(w_in), synapses(w_rec), synapses(w_out))
    layer = XyloLayer(
        synapses_in=kept[0],
        synapses_rec=kept[1],
        synapses_out=kept[2],
        aliases=[[] for _ in range(n_h)],
        threshold=[int(t) for t in spec["threshold"]],
        threshold_out=[int(t) for t in spec["threshold_out"]],
        has_bias=False,
        bias=[0] * n_h,
        bias_out=[0] * n_out,
        weight_shift_inp=int(spec["weight_shift_in"]),
        weight_shift_rec=int(spec["weight_shift_rec"]),
        weight_shift_out=int(spec["weight_shift_out"]),
        dash_mem=[int(d) for d in spec["dash_mem"]],
        dash_mem_out=[int(d) for d in spec["dash_mem_out"]],
        dash_syns=[[int(d)] for d in spec["dash_syn"]],
        dash_syns_out=[[int(d)] for d in spec["dash_syn_out"]],
        name="braille",
    )
    return layer, kept


def main(path):
    with open(path) as f:
        trace = json.load(f)
    spec = trace["spec"]
    sim, _kept = layer_of(spec)
    n_h = spec["n_hidden"]
    mismatched, first, hidden_ours, hidden_theirs, steps = 0, None, 0, 0, 0
    agree_pred = 0
    for k, s in enumerate(trace["samples"]):
        sim.reset_all()
        x = np.array(s["input"], dtype=np.int64)
        # the events per channel and step as the chip's input interface takes them (8 bits; the
        # simulator then takes at most 15)
        sim.evolve(np.minimum(x, 255).tolist())
        theirs = np.array(sim.rec_recurrent_spikes, dtype=np.int64).reshape(len(x), n_h)
        vmem_out = np.array(sim.rec_v_mem_out, dtype=np.int64).T
        ours = np.zeros_like(theirs)
        for t, j, n in s["hidden_spikes"]:
            ours[t, j] = n
        v_ours = np.array(s["v_mem_out"])
        hidden_ours += int(ours.sum())
        hidden_theirs += int(theirs.sum())
        steps += len(x)
        same = np.array_equal(ours, theirs) and np.array_equal(v_ours, np.asarray(vmem_out))
        pred = int(np.argmax(np.maximum(np.asarray(vmem_out), 0).max(axis=0)))
        agree_pred += pred == s["predicted"]
        if not same:
            mismatched += 1
            if first is None:
                bad = np.argwhere((ours != theirs).any(axis=1) | (v_ours != np.asarray(vmem_out)).any(axis=1))
                first = {"sample": k, "step": int(bad[0][0]) if len(bad) else None}
    summary = {
        "trace": path,
        "model": trace["model"],
        "split": trace["split"],
        "samples": len(trace["samples"]),
        "steps": steps,
        "hidden_spikes_engine": hidden_ours,
        "hidden_spikes_xylosim": hidden_theirs,
        "samples_differing": mismatched,
        "first_difference": first,
        "predictions_agreeing": agree_pred,
    }
    print(json.dumps(summary, indent=2))
    return 0 if mismatched == 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
