#!/usr/bin/env python3
"""Letters read after a letter pair the training boards hold, against after one they never hold.

A character classifier's window sees its neighbours' dots; a classifier that learnt the training
words' neighbours as context misreads letters after pairs it never saw. This splits a
`letters-report` JSON's letters by whether the pair (the letter before, the letter) stands inside
a word of the training boards, and counts the misreads of each part.

    braille train --recipe words --print-boards > boards.txt
    python3 scripts/pair_coverage.py boards.txt docs/results/nominal/val_letters.json

Scored as `letters-report` scores letters: words of a scan read at the printed word count, each
word read at its printed length (the rest, split or merged words, are left out here and counted
in the report's word accuracy). A word's first letter follows a space; it counts as after a
seen pair when some training word begins with it. Only `--arch` (default snn) is counted: the
report's examples are per architecture in `scores`.
"""

import argparse
import collections
import json
import sys


def training_pairs(path):
    """Ordered pairs inside words (and ' X' for word starts) of the boards at the cell spacing."""
    pairs = collections.Counter()
    spread = False
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.rstrip("\n")
            if line.startswith("# "):
                spread = "spread" in line
                continue
            if spread:
                continue  # SAB and UN: letters spread over the row, no neighbours at the cell spacing
            for word in line.split():
                pairs[" " + word[0]] += 1
                pairs.update(word[i : i + 2] for i in range(len(word) - 1))
    return pairs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("boards", help="`braille train ... --print-boards` output")
    ap.add_argument("letters", help="a letters-report JSON (letters.json or val_letters.json)")
    ap.add_argument("--arch", default="snn", choices=["snn", "resnet"])
    a = ap.parse_args()
    pairs = training_pairs(a.boards)
    report = json.load(open(a.letters, encoding="utf-8"))
    total = collections.Counter()
    wrong = collections.Counter()
    confusions = collections.Counter()
    for score in report["scores"]:
        if score["arch"] != a.arch:
            continue
        for printed, read, _lexicon in score["examples"]:
            pw, rw = printed.split(), read.split()
            if len(pw) != len(rw):
                continue
            for p, r in zip(pw, rw):
                if len(p) != len(r):
                    continue
                for i, (x, y) in enumerate(zip(p, r)):
                    seen = pairs[(p[i - 1] if i else " ") + x] > 0
                    total[seen] += 1
                    if x != y:
                        wrong[seen] += 1
                        if not seen:
                            confusions[f"{p[i - 1] if i else '^'}{x}->{y}"] += 1
    if not total:
        sys.exit(f"{a.letters}: no {a.arch} examples")
    print(f"| {a.letters}, {a.arch} | letters | misread |")
    print("| --- | --- | --- |")
    for seen, what in ((True, "after a pair the training boards hold"), (False, "after a pair they never hold")):
        n, w = total[seen], wrong[seen]
        print(f"| {what} | {n:,} | {w} ({100 * w / max(n, 1):.2f}%) |")
    held = sum(1 for k in pairs if k[0] != " ")
    print(f"\nletter pairs inside the training boards' words: {held} of 676")
    if confusions:
        print("after unseen pairs, most frequent:", ", ".join(f"{k} {v}" for k, v in confusions.most_common(8)))


if __name__ == "__main__":
    main()
