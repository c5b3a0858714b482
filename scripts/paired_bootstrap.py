#!/usr/bin/env python3
"""Is a gap between two models' three-seed mean accuracies beyond the test split's noise?

Paired bootstrap over the test samples: both sides' per-sample correctness (from `braille eval
--predictions`, one CSV per seed, the split's samples in file order) is resampled with the same
sample indices, and the difference of the seed-mean accuracies (A minus B) recomputed each time.
Prints the observed difference, its 95% interval and the share of resamples at or below zero.
Only models already scored on that split are compared: it chooses nothing.

    python3 scripts/paired_bootstrap.py --a A1.csv A2.csv A3.csv --b B1.csv B2.csv B3.csv [--seed 1]
"""
import argparse
import csv
import random


def correct(path):
    with open(path, newline="") as f:
        return [row["truth"] == row["predicted"] for row in csv.DictReader(f)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--a", nargs="+", required=True, help="side A's prediction CSVs, one per seed")
    ap.add_argument("--b", nargs="+", required=True, help="side B's prediction CSVs, one per seed")
    ap.add_argument("--resamples", type=int, default=10000)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    a = [correct(p) for p in args.a]
    b = [correct(p) for p in args.b]
    n = len(a[0])
    if any(len(x) != n for x in a + b):
        raise SystemExit(f"every CSV must hold the same {n} samples")
    # per sample: the share of seeds right, each side
    sa = [sum(x[i] for x in a) / len(a) for i in range(n)]
    sb = [sum(x[i] for x in b) / len(b) for i in range(n)]
    d = [p - q for p, q in zip(sa, sb)]
    observed = 100 * sum(d) / n
    rng = random.Random(args.seed)
    diffs = []
    for _ in range(args.resamples):
        diffs.append(100 * sum(d[rng.randrange(n)] for _ in range(n)) / n)
    diffs.sort()
    lo, hi = diffs[int(0.025 * len(diffs))], diffs[int(0.975 * len(diffs)) - 1]
    at_or_below = sum(x <= 0 for x in diffs) / len(diffs)
    disagree = sum(1 for x in d if x != 0)
    print(
        f"{n} samples: A {100 * sum(sa) / n:.2f}%, B {100 * sum(sb) / n:.2f}%, A - B {observed:+.2f} points, "
        f"95% interval [{lo:+.2f}, {hi:+.2f}] ({args.resamples} paired resamples, seed {args.seed}); "
        f"resamples with A - B <= 0: {at_or_below:.4f}; samples where the sides' seed means differ: {disagree}"
    )


if __name__ == "__main__":
    main()
