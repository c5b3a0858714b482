#!/usr/bin/env python3
"""Our exported NIR graphs run in snnTorch and in Norse through their own importers, spike for
spike against this project's engine (`braille run`). Outside CI: it needs the peers' Python
environment (see compare.sh): `python3 -m venv venv && ./venv/bin/pip install torch
snntorch==1.0.0 norse==1.1.0 nir==1.0.8 nirtorch==2.6`.

Each graph is exported by `braille export` in the convention each peer's importer takes as trained
(`--convention snntorch`: snnTorch 1.0 assumes a 100 us step; `--convention norse`: unit r and
w_in, the scales in the weights, since Norse 1.1's LIF drops r). Neither importer takes NIR's LI
node, so a model's leaky-integrator readout is cut off and its spiking layers are compared (our
engine runs the same cut graph). Where a peer's importer is known to be wrong for a graph
(../shared/golden/nir/README.md: snnTorch wires a recurrent subgraph's input into its recurrent
weights and runs IF with a leak of 0.9; Norse maps AvgPool2d to nothing), the row says so instead
of a number.

Usage (from the repository's root, after `cargo build --release`):
    venv/bin/python scripts/peers/nir_crosscheck.py [--out docs/results/nir_crosscheck.md]
"""
import argparse
import copy
import io
import json
import os
import subprocess
import sys
import tempfile
from contextlib import redirect_stdout

import numpy as np
import nir
import torch

BRAILLE = os.environ.get("BRAILLE", "target/release/braille")
FIXTURES = "snn/tests/fixtures/nir"


def sh(*args):
    r = subprocess.run([BRAILLE, *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"braille {' '.join(args)}: {r.stderr.strip()}")
    return r


def neuron_nodes(g):
    """The spiking neuron nodes in chain order from the input."""
    order, cur, seen = [], "input", set()
    succ = {}
    for a, b in g.edges:
        succ.setdefault(a, []).append(b)
    while cur is not None and cur not in seen:
        seen.add(cur)
        if isinstance(g.nodes[cur], (nir.LIF, nir.CubaLIF, nir.IF)):
            order.append(cur)
        nxt = [b for b in succ.get(cur, []) if b not in seen and not b.endswith("w_rec")]
        cur = nxt[0] if nxt else None
    return order


def cut_readout(g):
    """The graph without a leaky-integrator readout (its op and LI node), for importers without LI."""
    g = copy.deepcopy(g)
    li = [k for k, n in g.nodes.items() if isinstance(n, nir.LI)]
    if not li:
        return g, False
    (li,) = li
    op = next(a for a, b in g.edges if b == li)
    before = next(a for a, b in g.edges if b == op)
    for k in (li, op):
        del g.nodes[k]
    g.edges = [(a, b) for a, b in g.edges if a not in (li, op) and b not in (li, op)]
    g.edges.append((before, "output"))
    shape = np.asarray(g.nodes[before].output_type["output"])
    g.nodes["output"] = nir.Output(output_type={"output": shape})
    return g, True


def input_events(xs, dt_us, shape):
    """Spikes [T, n] as CSV events that `braille run` maps back onto the same inputs."""
    lines = ["t_us,x,y,p"]
    T = xs.shape[0]
    flat = xs.reshape(T, -1)
    n = flat.shape[1]
    if len(shape) == 3:
        c, h, w = shape
    elif n % 2 == 0:
        c, h, w = 2, 1, n // 2
    else:
        c, h, w = 1, 1, n
    for t in range(T):
        for i in np.nonzero(flat[t])[0]:
            ch, rest = divmod(int(i), h * w)
            y, x = divmod(rest, w)
            for _ in range(int(flat[t, i])):
                lines.append(f"{t * dt_us},{x},{y},{ch if c == 2 else 0}")
    return "\n".join(lines) + "\n"


def ours(graph_path, xs, dt_us, shape, tmp):
    ev = os.path.join(tmp, "in.csv")
    open(ev, "w").write(input_events(xs, dt_us, shape))
    out = os.path.join(tmp, "spikes.csv")
    sh("run", "--model", graph_path, "--events", ev, "--dt-us", str(dt_us), "--steps", str(xs.shape[0]), "--out", out)
    rows = np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.int64, ndmin=2)
    return rows


def raster(rows, layer, T, n):
    r = np.zeros((T, n), dtype=np.uint8)
    for l, t, j in rows:
        if l == layer:
            r[t, j] = 1
    return r


def run_snntorch(g, xs):
    import snntorch as snn
    from snntorch.import_nir import import_from_nir

    with redirect_stdout(io.StringIO()):
        net = import_from_nir(g)
    mods = []
    for m in net.modules():
        if isinstance(m, (snn.Leaky, snn.Synaptic)):
            def hook(mod, inp, out):
                mod._last_spk = (out[0] if isinstance(out, tuple) else out).detach()
            m.register_forward_hook(hook)
            mods.append(m)
    rec = [[] for _ in mods]
    state = None
    with torch.no_grad():
        for x in torch.from_numpy(xs.astype(np.float32)):
            _, state = net(x, state)
            for k, m in enumerate(mods):
                rec[k].append(m._last_spk.reshape(-1).numpy().copy())
    return [np.stack(r).astype(np.uint8) for r in rec]


def run_norse(g, xs, dt):
    import norse.torch as norse

    net = norse.from_nir(g, dt=dt)
    names = [n.replace(".", "_") for n in neuron_nodes(g)]
    rec = [[] for _ in names]
    state = None
    with torch.no_grad():
        for x in torch.from_numpy(xs.astype(np.float32)):
            _, state = net(x, state)
            for k, name in enumerate(names):
                rec[k].append(state.cache[name].reshape(-1).numpy().copy())
    return [np.stack(r).astype(np.uint8) for r in rec]


def compare(a_rows, b, T, sizes):
    res = []
    for k, n in enumerate(sizes):
        a = raster(a_rows, k, T, n)
        res.append((int(a.sum()), int(b[k].sum()), int((a != b[k]).sum())))
    return res


CASES = [
    # name, source (a model file or a NIR fixture imported at 100 us), steps, input rate, known problems
    ("dense fixture (Affine, LIF)", f"{FIXTURES}/dense/dense_snn.nir", 50, 0.1, {}),
    ("conv fixture (Conv2d, LIF, AvgPool2d)", f"{FIXTURES}/conv/conv_snn.nir", 20, 0.02,
     {"norse": "Norse 1.1's importer maps AvgPool2d to nothing"}),
    ("Braille recurrent CubaLIF fixture", f"{FIXTURES}/braille/braille_noDelay_bias_zero.nir", 100, 0.05,
     {"snntorch": "snnTorch 1.0's importer wires a recurrent subgraph's input into its recurrent weights"}),
    ("models/icub/nir/snn-raw1350 (recurrent CubaLIF, bias)", "models/icub/nir/snn-raw1350.safetensors", 100, 0.05,
     {"snntorch": "snnTorch 1.0's importer wires a recurrent subgraph's input into its recurrent weights"}),
    ("models/icub/nir/snn-th10 (recurrent CubaLIF, bias)", "models/icub/nir/snn-th10.safetensors", 100, 0.05,
     {"snntorch": "snnTorch 1.0's importer wires a recurrent subgraph's input into its recurrent weights"}),
    ("models/clean/nir/snn-chars (LIF)", "models/clean/nir/snn-chars.safetensors", 40, 0.05, {}),
    ("models/icub/chip/xylo-braille7 (CubaLIF)", "models/icub/chip/xylo-braille7.safetensors", 100, 0.05, {}),
    ("models/clean/chip/speck-chars (Conv2d, IF, SumPool2d)", "models/clean/chip/speck-chars.safetensors", 40, 0.05,
     {"snntorch": "snnTorch 1.0's importer runs IF with a leak of 0.9 and has no SumPool2d"}),
]


# Also exported in NIR's own convention (the model's step, r = tau / dt), to show what each
# importer makes of it.
SHOW_NIR_CONVENTION = {"models/icub/chip/xylo-braille7.safetensors", "models/clean/nir/snn-chars.safetensors"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs/results/nir_crosscheck.md")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, src, T, p, known in CASES:
            if not os.path.exists(src):
                rows.append((name, "-", "-", f"missing {src}"))
                continue
            if src.endswith(".nir"):
                model = os.path.join(tmp, "model.safetensors")
                sh("import", src, "--out", model, "--dt-us", "100", "--force")
            else:
                model = src
            runs = [("snntorch", "snntorch"), ("norse", "norse")]
            if src in SHOW_NIR_CONVENTION:
                runs += [("snntorch", "nir"), ("norse", "nir")]
            for peer, convention in runs:
                label = f"{peer} (`{convention}` convention)"
                if peer in known:
                    rows.append((name, label, "not run", known[peer]))
                    continue
                path = os.path.join(tmp, f"{peer}.nir")
                info = sh("export", "--model", model, "--out", path, "--convention", convention, "--force").stderr
                dt_s = float(info.split("import at dt = ")[1].split(" s")[0])
                g, cut = cut_readout(nir.read(path))
                cut_path = os.path.join(tmp, f"{peer}-cut.nir")
                nir.write(cut_path, g)
                shape = [int(v) for v in np.asarray(g.nodes["input"].input_type["input"]).reshape(-1)]
                n_in = int(np.prod(shape))
                rng = np.random.default_rng(7)
                xs = (rng.random((T, *shape)) < p).astype(np.uint8)
                dt_us = int(round(dt_s * 1e6))
                a = ours(cut_path, xs, dt_us, shape, tmp)
                try:
                    b = run_snntorch(g, xs) if peer == "snntorch" else run_norse(g, xs, dt_s)
                except Exception as e:  # a peer's importer refusing the graph is a result
                    rows.append((name, label, "error", f"{type(e).__name__}: {str(e)[:160]}"))
                    continue
                sizes = [int(np.prod(np.asarray(g.nodes[k].output_type["output"]))) for k in neuron_nodes(g)]
                c = compare(a, b, T, sizes)
                ok = all(m == 0 for _, _, m in c)
                detail = "; ".join(f"layer {k}: {x} / {y} spikes, {m} differ" for k, (x, y, m) in enumerate(c))
                if cut:
                    detail += " (LI readout cut: neither peer imports LI)"
                rows.append((name, label, "identical" if ok else "DIFFER", detail))
                print(name, label, "identical" if ok else "DIFFER", detail, flush=True)
    versions = {}
    for m in ("torch", "snntorch", "norse", "nir", "nirtorch"):
        try:
            versions[m] = __import__(m).__version__
        except Exception:
            versions[m] = "?"
    md = ["# Our NIR graphs in snnTorch and Norse, spike for spike", "",
          f"Regenerate: `venv/bin/python scripts/peers/nir_crosscheck.py` (outside CI; {', '.join(f'{k} {v}' for k, v in versions.items())}).",
          "Each graph is exported by `braille export --convention snntorch|norse`, run on the same random input spikes by the peer's own importer and by `braille run` (our engine), and every spike of every spiking layer compared (ours / the peer's).", "",
          "| graph | peer (export convention) | result | spikes (ours / peer's) |", "| --- | --- | --- | --- |"]
    md += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in rows]
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    open(args.out, "w").write("\n".join(md) + "\n")
    json.dump(rows, open(args.out.replace(".md", ".json"), "w"), indent=1)
    print("\n".join(md))


if __name__ == "__main__":
    main()
