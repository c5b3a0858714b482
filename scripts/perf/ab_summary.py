#!/usr/bin/env python3
"""Reads the rounds of scripts/perf/ab.sh: per build, the figure after LABEL on each line (e.g.
`fastest`, `median`); then the paired ratios (after / before, round by round), their median and
in how many rounds the build after was lower.

    python3 scripts/perf/ab_summary.py AB_OUTPUT [LABEL]

A median ratio within LAYOUT_BAND of 1 is flagged: on the engine benchmark the heap's layout alone
(where the allocator places the buffers, the code unchanged) moved the ratio by 0.97-1.03
(docs/engine.md, "the 2026-12-04 14:33Z session"), so a change that small may be the layout it leaves.
"""
import re
import statistics
import sys

LAYOUT_BAND = 0.03


def main() -> None:
    path = sys.argv[1]
    label = sys.argv[2] if len(sys.argv) > 2 else "fastest"
    pattern = re.compile(re.escape(label) + r"\s+([0-9.]+)")
    rounds: dict[str, dict[str, float]] = {}
    order: list[str] = []
    for line in open(path):
        parts = line.split(maxsplit=2)
        m = pattern.search(line)
        if len(parts) < 3 or not m:
            continue
        rnd, name = parts[0], parts[1]
        if name not in order:
            order.append(name)
        rounds.setdefault(rnd, {})[name] = float(m.group(1))
    if len(order) != 2:
        sys.exit(f"expected two builds in {path}, found {order}")
    before, after = order
    pairs = [(r[before], r[after]) for r in rounds.values() if before in r and after in r]
    if not pairs:
        sys.exit(f"no round of {path} has both builds")
    ratios = [a / b for b, a in pairs]
    median = statistics.median(ratios)
    print(f"{before} {label}: " + " ".join(f"{b:g}" for b, _ in pairs))
    print(f"{after} {label}: " + " ".join(f"{a:g}" for _, a in pairs))
    print(
        f"{after} / {before}: median paired ratio {median:.3f}, lower in "
        f"{sum(r < 1 for r in ratios)} of {len(ratios)} rounds; lowest {min(b for b, _ in pairs):g} "
        f"against {min(a for _, a in pairs):g}"
    )
    if abs(median - 1) <= LAYOUT_BAND:
        print(f"within {LAYOUT_BAND:.0%} of 1: the size of a heap-layout effect (docs/engine.md, \"the 2026-12-04 14:33Z session\")")


if __name__ == "__main__":
    main()
