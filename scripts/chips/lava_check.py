#!/usr/bin/env python3
"""Spike-for-spike check of the engine's Loihi 2 arithmetic against Intel's Lava.

Reads a trace from `braille eval --chip loihi2 --trace TRACE.json` (or `braille eval chars --chip
loihi2 --trace`): the model mapped to Loihi 2's formats (per layer: Lava's integer weights and
weight exponent, du, dv, vth, bias mantissa and exponent, an optional recurrent block) and every
sample as the engine ran it, its drain steps included. Then, with PyPI `lava-nc` (0.10.0, which
needs Python 3.10), each sample runs through Lava's own processes and bit-accurate models
(`Loihi2SimCfg(select_tag="fixed_pt")`: `PyDenseModelBitAcc`, `PyLifModelBitAcc`):

    RingBuffer (the input events as graded spikes) -> Dense -> LIF -> Dense -> LIF ...

(a recurrent layer's LIF also feeds a `Dense` back into itself; a convolution, and a sum pooling
before it, are written out as the `Dense` matrix they make), and every layer's spikes at every
step, and the output layer's membranes, are compared with the engine's.

Prints a JSON summary; exits 1 on any difference.

    python3.10 scripts/chips/lava_check.py TRACE.json [--samples N]
"""

import argparse
import json
import sys

import numpy as np


def conv_matrix(in_shape, op, weights):
    """`[post][pre]` matrix of a Conv (PyTorch layout) or Dense op over `in_shape`."""
    c, h, w = in_shape
    if "Dense" in op:
        n_out = op["Dense"]["n_out"]
        return np.asarray(weights, dtype=np.int32).reshape(n_out, c * h * w)
    cv = op["Conv"]
    oc, (kh, kw), (sy, sx), (py, px) = cv["out_channels"], cv["kernel"], cv["stride"], cv["padding"]
    oh = (h + 2 * py - kh) // sy + 1
    ow = (w + 2 * px - kw) // sx + 1
    k = np.asarray(weights, dtype=np.int32).reshape(oc, c, kh, kw)
    m = np.zeros((oc * oh * ow, c * h * w), dtype=np.int32)
    for o in range(oc):
        for y in range(oh):
            for x in range(ow):
                post = (o * oh + y) * ow + x
                for ci in range(c):
                    for ky in range(kh):
                        iy = y * sy + ky - py
                        if not 0 <= iy < h:
                            continue
                        for kx in range(kw):
                            ix = x * sx + kx - px
                            if 0 <= ix < w:
                                m[post, (ci * h + iy) * w + ix] = k[o, ci, ky, kx]
    return m


def layer_matrix(layer):
    """The layer's feed-forward `[post][pre]` matrix over its unpooled input."""
    c, h, w = layer["in_shape"]
    p = layer["pool"]
    pooled = [c, h // p, w // p]
    m = conv_matrix(pooled, layer["op"], layer["weights"])
    if p == 1:
        return m
    oh, ow = h // p, w // p
    full = np.zeros((m.shape[0], c * h * w), dtype=np.int32)
    for j in range(c * h * w):
        ch, y, x = j // (h * w), (j // w) % h, j % w
        if y // p < oh and x // p < ow:
            full[:, j] = m[:, (ch * oh + y // p) * ow + x // p]
    return full


def run_lava(spec, sample, n_in):
    from lava.magma.core.run_conditions import RunSteps
    from lava.magma.core.run_configs import Loihi2SimCfg
    from lava.proc.dense.process import Dense
    from lava.proc.io.source import RingBuffer
    from lava.proc.lif.process import LIF
    from lava.proc.monitor.process import Monitor
    from lava.utils.weightutils import SignMode

    steps = sample["steps"]
    x = np.zeros((n_in, steps), dtype=np.int32)
    for k, c, n in sample["input"]:
        x[c, k] = n
    src = RingBuffer(data=x)
    prev = src.s_out
    lifs = []
    for i, layer in enumerate(spec["layers"]):
        n = None
        d = Dense(
            weights=layer_matrix(layer),
            weight_exp=layer["weight_exp"],
            num_message_bits=16 if i == 0 else 0,
            sign_mode=SignMode.MIXED,
        )
        n = d.a_out.shape[0]
        bias_mant = np.asarray(layer["bias_mant"] or [0] * n, dtype=np.int32)
        bias_exp = np.asarray(layer["bias_exp"] or [0] * n, dtype=np.int32)
        lif = LIF(shape=(n,), du=layer["du"], dv=layer["dv"], vth=layer["vth"], bias_mant=bias_mant, bias_exp=bias_exp)
        prev.connect(d.s_in)
        d.a_out.connect(lif.a_in)
        if layer["recurrent"] is not None:
            r = Dense(
                weights=np.asarray(layer["recurrent"], dtype=np.int32).reshape(n, n),
                weight_exp=layer["recurrent_weight_exp"],
                sign_mode=SignMode.MIXED,
            )
            lif.s_out.connect(r.s_in)
            r.a_out.connect(lif.a_in)
        lifs.append(lif)
        prev = lif.s_out
    monitors = []
    for lif in lifs:
        m = Monitor()
        m.probe(lif.s_out, steps)
        monitors.append(m)
    mv = Monitor()
    mv.probe(lifs[-1].v, steps)
    try:
        src.run(condition=RunSteps(num_steps=steps), run_cfg=Loihi2SimCfg(select_tag="fixed_pt"))
        spikes = []
        for li, (lif, m) in enumerate(zip(lifs, monitors)):
            s = m.get_data()[lif.name]["s_out"]  # [steps][n]
            for k, j in zip(*np.nonzero(s)):
                spikes.append([int(k), li, int(j)])
        v = mv.get_data()[lifs[-1].name]["v"].astype(np.int64).tolist()
    finally:
        src.stop()
    spikes.sort()
    return spikes, v


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trace")
    ap.add_argument("--samples", type=int, default=None, help="the first N samples (default: all)")
    args = ap.parse_args()
    with open(args.trace) as f:
        trace = json.load(f)
    if trace.get("chip") != "loihi2":
        sys.exit(f"{args.trace}: a Loihi 2 trace is needed (braille eval --chip loihi2 --trace), this is {trace.get('chip')}")
    spec = trace["spec"]
    first = spec["layers"][0]
    n_in = int(np.prod(first["in_shape"]))
    samples = trace["samples"][: args.samples] if args.samples else trace["samples"]
    import lava

    mismatched = []
    n_spikes = 0
    for i, s in enumerate(samples):
        spikes, v = run_lava(spec, s, n_in)
        ours = sorted(list(map(list, s["spikes"])))
        n_spikes += len(ours)
        if spikes != ours or v != s["v_out"]:
            first_diff = next((k for k in range(s["steps"]) if v[k] != s["v_out"][k]), None)
            mismatched.append({"sample": i, "lava_spikes": len(spikes), "engine_spikes": len(ours), "first_membrane_difference_step": first_diff})
    out = {
        "trace": args.trace,
        "model": trace.get("model"),
        "lava": getattr(lava, "__version__", "0.10.0"),
        "samples": len(samples),
        "spikes": n_spikes,
        "identical": len(samples) - len(mismatched),
        "mismatched": mismatched[:10],
    }
    print(json.dumps(out, indent=2))
    sys.exit(1 if mismatched else 0)


if __name__ == "__main__":
    main()
