#!/usr/bin/env python3
"""A small snnTorch model trained on the iCub Braille events (th10, REAL), exported to NIR, and
run on the braille engine from Python beside snnTorch on the same events, with both timings.

Not run by CI (it needs torch and snnTorch):

    python -m pip install ./python torch snntorch==1.0.0 nir==1.0.8 nirtorch==2.6
    python python/examples/snntorch_icub.py [--epochs 10] [--out model.nir]

The network is 24 inputs (12 taxels x OFF/ON) -> 128 LIF -> 27 LIF, 5 ms steps, neurons that
reset to zero (what NIR encodes; snnTorch's default, subtraction, it cannot). The split is the
dataset's fixed train/test split; the epochs are fixed in advance (nothing is chosen on the test
split). The exported graph says dt = 1e-4 s (snnTorch's exporter), so our engine imports it at
100 us and each 5 ms bin becomes one 100 us step.
"""

import argparse
import csv
import os
import pathlib
import tempfile
import time

import numpy as np
import snntorch as snn
import torch
from snntorch import functional as SF
from snntorch import surrogate, utils
from snntorch.export_nir import export_to_nir

import neurobraille
import nir

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "icub_braille" / "th10"
BIN_S = 0.005
STEPS = 262  # 1.31 s of 5 ms bins: every th10 sample fits
TAXELS = 12


def load():
    """Per sample: events (bin, input) with input = polarity * 12 + taxel; labels; split."""
    labels, split = {}, {}
    with open(DATA / "samples.csv") as f:
        for r in csv.DictReader(f):
            labels[int(r["sample"])] = int(r["label"])
    with open(DATA / "split.csv") as f:
        for r in csv.DictReader(f):
            split[int(r["sample"])] = r["split"]
    events = {s: [] for s in labels}
    with open(DATA / "events.csv") as f:
        for r in csv.DictReader(f):
            b = min(int(float(r["t_s"]) / BIN_S), STEPS - 1)
            events[int(r["sample"])].append((b, int(r["pol"]) * TAXELS + int(r["taxel"])))
    return events, labels, split


def dense(evs):
    x = np.zeros((STEPS, 2 * TAXELS), dtype=np.float32)
    for b, i in evs:
        x[b, i] += 1.0
    return x


def as_events(evs):
    """The same sample as Tonic's array for our engine: one 100 us step per 5 ms bin, pixel
    (taxel, 0), polarity; a flat input of 24 reads as 2 x 1 x 12."""
    a = np.empty(len(evs), dtype=neurobraille.EVENTS_DTYPE)
    a["t"] = [b * 100 for b, _ in evs]
    a["x"] = [i % TAXELS for _, i in evs]
    a["y"] = 0
    a["p"] = [i // TAXELS for _, i in evs]
    return a


def make_net(hidden=128, classes=27):
    """Linear -> Leaky -> Linear -> Leaky, one step per call. beta and threshold are per-neuron
    tensors: snnTorch 1.0 with nir 1.0.8 cannot export a scalar beta after a Linear."""
    grad = surrogate.fast_sigmoid(slope=25)

    def lif(n, output=False):
        return snn.Leaky(
            beta=torch.full((n,), 0.95),
            threshold=torch.ones(n),
            spike_grad=grad,
            reset_mechanism="zero",
            init_hidden=True,
            output=output,
        )

    return torch.nn.Sequential(
        torch.nn.Linear(2 * TAXELS, hidden), lif(hidden), torch.nn.Linear(hidden, classes), lif(classes, True)
    )


def forward(net, x):
    """x: [T, B, 24] -> output spikes [T, B, 27]."""
    utils.reset(net)
    return torch.stack([net(x[t])[0] for t in range(x.shape[0])])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--epochs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--timed", type=int, default=200, help="test samples timed one by one")
    ap.add_argument("--out", help="keep the NIR graph here")
    args = ap.parse_args()
    torch.manual_seed(args.seed)
    np.random.seed(args.seed)
    torch.set_num_threads(1)

    events, labels, split = load()
    train = [s for s in sorted(labels) if split[s] == "train"]
    test = [s for s in sorted(labels) if split[s] == "test"]
    xtr = torch.tensor(np.stack([dense(events[s]) for s in train])).transpose(0, 1)
    ytr = torch.tensor([labels[s] for s in train])
    xte = torch.tensor(np.stack([dense(events[s]) for s in test])).transpose(0, 1)
    yte = np.array([labels[s] for s in test])

    net = make_net()
    opt = torch.optim.Adam(net.parameters(), lr=2e-3)
    loss_fn = SF.ce_count_loss()
    t0 = time.perf_counter()
    for epoch in range(args.epochs):
        perm = torch.randperm(len(train))
        for k in range(0, len(train), 64):
            idx = perm[k : k + 64]
            loss = loss_fn(forward(net, xtr[:, idx]), ytr[idx])
            opt.zero_grad()
            loss.backward()
            opt.step()
        print(f"epoch {epoch + 1}: loss {loss.item():.3f}")
    print(f"trained {args.epochs} epochs in {time.perf_counter() - t0:.0f} s (snnTorch {snn.__version__}, 1 thread)")

    with torch.no_grad():
        torch_pred = forward(net, xte).sum(0).argmax(1).numpy()

    # export, and load the graph into our engine
    out = args.out or os.path.join(tempfile.mkdtemp(), "icub_snntorch.nir")
    nir.write(out, export_to_nir(net, torch.zeros(1, 2 * TAXELS), ignore_dims=[0]))
    ours = neurobraille.Network.load(out, dt_us=100)
    print(ours)
    samples = [as_events(events[s]) for s in test]
    end_us = STEPS * 100
    our_pred = np.array([r.prediction for r in ours.run_batch(samples, t_end_us=end_us)])

    print(f"\ntest split ({len(test)} samples, REAL):")
    print(f"  snnTorch accuracy        {np.mean(torch_pred == yte) * 100:.2f}%")
    print(f"  braille engine accuracy  {np.mean(our_pred == yte) * 100:.2f}%")
    print(f"  same prediction          {np.mean(torch_pred == our_pred) * 100:.2f}% of samples")

    # timing, one sample at a time (a stream's view), the same samples
    k = min(args.timed, len(test))
    with torch.no_grad():
        t0 = time.perf_counter()
        for j in range(k):
            forward(net, xte[:, j : j + 1])
        torch_ms = (time.perf_counter() - t0) / k * 1e3
    t0 = time.perf_counter()
    for j in range(k):
        ours.run(samples[j], t_end_us=end_us)
    ours_ms = (time.perf_counter() - t0) / k * 1e3
    # and the whole test split at once
    with torch.no_grad():
        t0 = time.perf_counter()
        forward(net, xte)
        torch_batch_ms = (time.perf_counter() - t0) / len(test) * 1e3
    t0 = time.perf_counter()
    ours.run_batch(samples, t_end_us=end_us)
    ours_batch_ms = (time.perf_counter() - t0) / len(test) * 1e3
    print(f"\nper sample ({STEPS} steps, mean {np.mean([len(s) for s in samples]):.1f} input events):")
    print(f"  one at a time: snnTorch {torch_ms:.3f} ms, braille {ours_ms:.3f} ms ({torch_ms / ours_ms:.1f}x)")
    print(
        f"  whole split:   snnTorch {torch_batch_ms:.3f} ms (batch {len(test)}, 1 thread), "
        f"braille {ours_batch_ms:.3f} ms (run_batch, {os.cpu_count()} cores) ({torch_batch_ms / ours_batch_ms:.1f}x)"
    )


if __name__ == "__main__":
    main()
