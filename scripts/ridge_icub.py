#!/usr/bin/env python3
"""Ridge regression on time-binned sigma-delta event counts of data/icub_braille/raw1350 (fixed
split), per bin width: how much of the letters' information lies in timing. NumPy only.
Usage: python3 scripts/ridge_icub.py"""
import csv
from collections import defaultdict
import numpy as np

ROOT = "data/icub_braille/raw1350"
rows = list(csv.reader(open(f"{ROOT}/raw.csv")))[1:]
split = {int(r[0]): r[1] for r in list(csv.reader(open(f"{ROOT}/split.csv")))[1:]}
frames, label = defaultdict(list), {}
for r in rows:
    s = int(r[0]); label[s] = int(r[2]); frames[s].append([float(x) for x in r[5:]])


def sigma_delta(fr, th=2.0):
    """ON/OFF events (ms, taxel, polarity) each time a taxel moves `th` from its reference."""
    fr = np.array(fr); ref = fr[0].copy(); ev = []
    for t in range(1, len(fr)):
        for c in range(fr.shape[1]):
            while fr[t, c] - ref[c] >= th: ref[c] += th; ev.append((t * 25, c, 1))
            while ref[c] - fr[t, c] >= th: ref[c] -= th; ev.append((t * 25, c, 0))
    return ev


events = {s: sigma_delta(frames[s]) for s in frames}
ids = sorted(frames)
y = np.array([label[s] for s in ids]); train = np.array([split[s] == "train" for s in ids])
for bin_ms in [2000, 400, 200, 100, 50]:
    nb = int(np.ceil(1925 / bin_ms))
    X = np.zeros((len(ids), nb, 2, 12))
    for k, s in enumerate(ids):
        for t, c, p in events[s]:
            X[k, min(t // bin_ms, nb - 1), p, c] += 1
    X = X.reshape(len(ids), -1)
    X = (X - X[train].mean(0)) / (X[train].std(0) + 1e-6)
    X = np.c_[X, np.ones(len(X))]
    Y = np.eye(27)[y] * 2 - 1
    best = 0.0
    for lam in [0.1, 1, 10, 100, 1000]:
        W = np.linalg.solve(X[train].T @ X[train] + lam * np.eye(X.shape[1]), X[train].T @ Y[train])
        best = max(best, (np.argmax(X[~train] @ W, 1) == y[~train]).mean())
    print(f"bins of {bin_ms} ms: ridge test accuracy {100 * best:.1f}% (best of 5 ridge strengths)")
