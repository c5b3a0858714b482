#!/usr/bin/env python3
"""Scores `braille eval words --json` runs by place and by letter (used for choices on the
validation boards, docs/log/letters-2026-11-29.md).

    python3 scripts/score_words_json.py RUN.json [RUN.json ...]

For each run: word accuracy (1 - WER) and CER as the run reports them; the first word of a row
read right (the line's first read word equals it) and the later words (aligned from the row's
end: the k-th word from the end against the k-th read word from the end, so a split first word
costs only the first word); then the letters of words whose word and letter counts were read
right, the eight least often read right and the ten most frequent confusions (printed>read).
The reading without spelling (the examples' second column)."""
import json
import sys
from collections import Counter

for path in sys.argv[1:]:
    run = json.load(open(path))
    run = run[0] if isinstance(run, list) else run
    first, later = [0, 0], [0, 0]
    printed, right, confusions = Counter(), Counter(), Counter()
    for example in run["examples"]:
        truth, read = example[0].split(), example[1].split()
        first[1] += 1
        first[0] += bool(read) and read[0] == truth[0]
        for k in range(1, len(truth)):
            later[1] += 1
            at = len(read) - (len(truth) - k)
            later[0] += 0 < at < len(read) and read[at] == truth[k]
        if len(truth) != len(read):
            continue
        for t, r in zip(truth, read):
            if len(t) != len(r):
                continue
            for a, b in zip(t, r):
                printed[a] += 1
                right[a] += a == b
                if a != b:
                    confusions[(a, b)] += 1
    print(f"{path}: word accuracy {run['word_accuracy']:.4f}, CER {run['cer']:.4f}, "
          f"first word {first[0] / first[1]:.3f} of {first[1]}, later words {later[0] / later[1]:.3f} of {later[1]}")
    worst = sorted((right[c] / printed[c], c) for c in printed)[:8]
    print("  lowest letters: " + ", ".join(f"{c} {100 * a:.1f}% of {printed[c]}" for a, c in worst))
    print("  confusions: " + ", ".join(f"{a}>{b} {n}" for (a, b), n in confusions.most_common(10)))
