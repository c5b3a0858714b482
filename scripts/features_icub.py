#!/usr/bin/env python3
"""Non-spiking probes on data/icub_braille/th10 (fixed split): gradient-boosted trees, extra trees
and logistic regression on hand-made features of each sample's events (ON/OFF counts per taxel in
5, 10 or 20 time bins over 1.3 s, and each channel's first-event time). How much a conventional
classifier finds in these 41-event samples. Needs NumPy and scikit-learn; seeded.
Usage: python3 scripts/features_icub.py"""
import collections
import csv

import numpy as np
from sklearn.ensemble import ExtraTreesClassifier, HistGradientBoostingClassifier
from sklearn.linear_model import LogisticRegression
from sklearn.preprocessing import StandardScaler

ROOT = "data/icub_braille/th10"
events = collections.defaultdict(list)
for r in csv.DictReader(open(f"{ROOT}/events.csv")):
    events[int(r["sample"])].append((float(r["t_s"]), int(r["taxel"]), int(r["pol"])))
samples = list(csv.DictReader(open(f"{ROOT}/samples.csv")))
split = {int(r["sample"]): r["split"] for r in csv.DictReader(open(f"{ROOT}/split.csv"))}


def features(k, bins):
    counts = np.zeros((24, bins))
    first = np.full(24, 1.4)
    for t, taxel, pol in events[k]:
        c = taxel * 2 + pol
        counts[c, min(int(t / 1.3 * bins), bins - 1)] += 1
        first[c] = min(first[c], t)
    return np.concatenate([counts.ravel(), first])


y = np.array([int(s["label"]) for s in samples])
keys = [int(s["sample"]) for s in samples]
train = np.array([split[k] == "train" for k in keys])
for bins in [5, 10, 20]:
    x = np.array([features(k, bins) for k in keys])
    x = StandardScaler().fit(x[train]).transform(x)
    for name, model in [
        ("logistic regression", LogisticRegression(C=0.1, max_iter=2000)),
        ("extra trees", ExtraTreesClassifier(500, random_state=0, n_jobs=2)),
        ("gradient-boosted trees", HistGradientBoostingClassifier(max_iter=300, random_state=0)),
    ]:
        model.fit(x[train], y[train])
        print(f"{bins} bins, {name}: test accuracy {(model.predict(x[~train]) == y[~train]).mean():.3f}")
