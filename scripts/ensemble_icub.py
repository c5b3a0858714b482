#!/usr/bin/env python3
"""Soft voting and the oracle over several models' predictions on one split: each file is what
`braille eval --data DIR --split SPLIT --model M --predictions FILE` writes (a row per sample:
index, truth, predicted, one readout per class). Soft voting takes the class with the largest
sum of readouts; the oracle counts a sample as right when any model is. Standard library only.
Usage: python3 scripts/ensemble_icub.py A.csv B.csv [C.csv ...]"""
import csv
import sys


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0][3:], rows[1:]


def main(paths):
    if len(paths) < 2:
        sys.exit(__doc__)
    loaded = [load(p) for p in paths]
    header, first = loaded[0]
    for p, (h, rows) in zip(paths, loaded):
        if h != header or [r[:2] for r in rows] != [r[:2] for r in first]:
            sys.exit(f"{p}: other classes or samples than {paths[0]}")
    classes = [h.removeprefix("readout_") for h in header]
    n = len(first)
    soft = oracle = 0
    for i in range(n):
        truth = first[i][1]
        total = [sum(float(rows[i][3 + c]) for _, rows in loaded) for c in range(len(classes))]
        soft += classes[max(range(len(classes)), key=total.__getitem__)] == truth
        oracle += any(rows[i][2] == truth for _, rows in loaded)
    for p, (_, rows) in zip(paths, loaded):
        print(f"{p}: {sum(r[1] == r[2] for r in rows) / n:.4f}")
    print(f"soft voting of {len(paths)}: {soft / n:.4f} ({soft}/{n})")
    print(f"oracle (any model right): {oracle / n:.4f} ({oracle}/{n})")


if __name__ == "__main__":
    main(sys.argv[1:])
