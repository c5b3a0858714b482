#!/usr/bin/env python3
"""The table of scripts/peers/resnet.sh: our ResNet inference (folded path and burn's) against
PyTorch's, per preset, batch 1 on one thread and batch 32 on the run's threads, from one run's
JSON lines (Markdown on stdout)."""
import json
import sys

path = sys.argv[1] if len(sys.argv) > 1 else "resnet_results.jsonl"
lines = open(path).read().splitlines()
rows = [json.loads(l) for l in lines if l.startswith("{")]
stamp = next((l[2:].strip() for l in lines if l.startswith("# 20")), "")
torch = {(r["model"].removeprefix("resnet-"), r["batch"]): r for r in rows if r.get("fw") == "torch"}
ours = [r for r in rows if "rows" in r]

print(f"Measured {stamp}.\n")
print(f"ms per window, medians; ratios are PyTorch's time over ours (above 1: ours")
print("faster). `sparse input`: windows with the run's share of non-zero cells, where our stem scatters the")
print("non-zero inputs (less work than a dense convolution: the ratio is not like for like); `dense input`:")
print("every cell non-zero, our stem a dense convolution (the same work as PyTorch's). `ours`: the reader's")
print("path (convolutions computed directly where the CPU has AVX2 and FMA"
      + (", as here" if any(r.get("direct_convolution") for r in ours) else "; not here") + ");")
print("`ours, im2col`: the same with every dense convolution by im2col and `gemm` (a CPU without them).")
print("burn: the same model on burn's `flex` backend. All three timed in the same bench call.\n")
print("| preset (input) | batch, threads | input to ours | ours | ours, im2col | burn | PyTorch | PyTorch / ours | PyTorch / ours, im2col | burn / ours |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for r in ours:
    preset = r["preset"]
    dense = r["density"] > 0.99
    for row in r["rows"]:
        t = torch.get((preset, row["batch"]))
        tm = t["per_sample_ms"] if t else None
        f, b = row["folded"]["ms_per_window"], row["burn"]["ms_per_window"]
        shape = "x".join(map(str, r["input"]))
        kind = "dense" if dense else f"sparse ({100 * r['density']:.1f}% non-zero)"
        i = (row.get("folded_im2col") or {}).get("ms_per_window")
        peer, ratio = (f"{tm:.3f}", f"**{tm / f:.2f}x**") if tm else ("n/a", "n/a")
        ims, iratio = (f"{i:.3f}", f"{tm / i:.2f}x" if tm else "n/a") if i else ("(the same)", "")
        print(f"| {preset} ({shape}) | {row['batch']}, {row['threads']} | {kind} | {f:.3f} | {ims} | {b:.3f} | {peer} | {ratio} | {iratio} | {b / f:.2f}x |")
print("\nLargest logit difference of ours against burn's over the windows, absolute (relative to the logit): "
      + ", ".join(f"{r['preset']} {'dense' if r['density'] > 0.99 else 'sparse'} {r['max_abs_logit_difference']:.1e} "
                  f"({r.get('max_rel_logit_difference', float('nan')):.1e})" for r in ours) + ".")
