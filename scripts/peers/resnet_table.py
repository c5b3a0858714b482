#!/usr/bin/env python3
"""The table of scripts/peers/resnet.sh: our ResNet inference (folded path and burn's) against
PyTorch's (batch norm folded by torch.fx, as ours), per preset, batch 1 on one thread and batch 32
on the run's threads, from one run's JSON lines (Markdown on stdout). With several interleaved
rounds, each time is the median over the rounds and each ratio is taken within its round, then
its median and range printed."""
import json
import statistics
import sys

path = sys.argv[1] if len(sys.argv) > 1 else "resnet_results.jsonl"
lines = open(path).read().splitlines()
rows = [json.loads(l) for l in lines if l.startswith("{")]
stamp = next((l[2:].strip() for l in lines if l.startswith("# 20")), "")
rounds = sorted({r.get("round", 1) for r in rows})
preset_of = lambda r: r.get("preset") or r["model"].removeprefix("resnet-")
torch = {(preset_of(r), r["batch"], r.get("round", 1)): r for r in rows if r.get("fw") == "torch"}
ours = [r for r in rows if "rows" in r]
folded_torch = {r.get("batch_norm_folded", False) for r in rows if r.get("fw") == "torch"}

print(f"Measured {stamp}.\n")
print(f"{len(rounds)} round(s), interleaved: in each round and preset PyTorch ran, then ours. ms per window,")
print("medians over the rounds; ratios are PyTorch's time over ours (above 1: ours faster), taken within")
print("each round, their median and [range] over the rounds. PyTorch's batch norm "
      + ("folded into the convolutions (torch.fx), as ours is: the same work. " if folded_torch == {True} else "NOT folded (ours is). "))
print("`sparse input`: windows with the run's share of non-zero cells, where our stem scatters the")
print("non-zero inputs (less work than a dense convolution: the ratio is not like for like); `dense input`:")
print("every cell non-zero, our stem a dense convolution (the same work as PyTorch's). `ours`: the reader's")
print("path (convolutions computed directly where the CPU has AVX2 and FMA"
      + (", as here" if any(r.get("direct_convolution") for r in ours) else "; not here") + ");")
print("`ours, im2col`: the same with every dense convolution by im2col and `gemm` (a CPU without them).")
print("burn: the same model on burn's `flex` backend. All three timed in the same bench call.\n")
print("| preset (input) | batch, threads | input to ours | ours | ours, im2col | burn | PyTorch | PyTorch / ours [range] | PyTorch / ours, im2col | burn / ours |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
med = statistics.median
cells = {}
for r in ours:
    dense = r["density"] > 0.99
    for row in r["rows"]:
        key = (preset_of(r), "x".join(map(str, r["input"])), row["batch"], row["threads"],
               "dense" if dense else f"sparse ({100 * r['density']:.1f}% non-zero)")
        cells.setdefault(key, []).append((r.get("round", 1), row))
def fmt_ratio(rs, bold=False):
    if not rs:
        return "n/a"
    m = f"{med(rs):.2f}x"
    m = f"**{m}**" if bold else m
    return m + (f" [{min(rs):.2f}-{max(rs):.2f}]" if len(rs) > 1 else "")
for (preset, shape, batch, threads, kind), entries in cells.items():
    f = [row["folded"]["ms_per_window"] for _, row in entries]
    b = [row["burn"]["ms_per_window"] for _, row in entries]
    i = [(row.get("folded_im2col") or {}).get("ms_per_window") for _, row in entries]
    t = [torch[(preset, batch, k)]["per_sample_ms"] if (preset, batch, k) in torch else None for k, _ in entries]
    ratio = [tk / fk for tk, fk in zip(t, f) if tk]
    iratio = [tk / ik for tk, ik in zip(t, i) if tk and ik]
    burn_ratio = [bk / fk for bk, fk in zip(b, f)]
    tm = [x for x in t if x]
    peer = f"{med(tm):.3f}" if tm else "n/a"
    ims = f"{med([x for x in i if x]):.3f}" if all(i) else "(the same)"
    print(f"| {preset} ({shape}) | {batch}, {threads} | {kind} | {med(f):.3f} | {ims} | {med(b):.3f} | {peer} | "
          f"{fmt_ratio(ratio, True)} | {fmt_ratio(iratio) if all(i) else ''} | {fmt_ratio(burn_ratio)} |")
print("\nLargest logit difference of ours against burn's over the windows, absolute (relative to the logit), first round: "
      + ", ".join(f"{preset_of(r)} {'dense' if r['density'] > 0.99 else 'sparse'} {r['max_abs_logit_difference']:.1e} "
                  f"({r.get('max_rel_logit_difference', float('nan')):.1e})" for r in ours if r.get("round", 1) == rounds[0]) + ".")
