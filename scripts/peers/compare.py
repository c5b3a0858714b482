#!/usr/bin/env python3
"""Ratios of this project's engine and trainer against the peers, from one compare.sh run."""
import json
import sys

rows = [json.loads(l) for l in open(sys.argv[1] if len(sys.argv) > 1 else "results.jsonl") if l.startswith("{")]
stamp = next((l[2:].strip() for l in open(sys.argv[1] if len(sys.argv) > 1 else "results.jsonl") if l.startswith("# 20")), "")
peers = {(r["mode"], r["fw"]): r for r in rows if "fw" in r}
ours_infer = next(r for r in rows if "ms_per_sample" in r)
ours_train = next(r for r in rows if "ms_per_train_step" in r)
names = {"torch": "plain PyTorch", "snntorch": "snnTorch", "norse": "Norse"}
cpu = next((r["cpu"] for r in rows if "cpu" in r), "?")
print(f"Measured {stamp} on {cpu}, {rows[0].get('threads', '?')} threads (peers).\n")
print("| conv SNN, batch 1 | ms / sample | us / input event | ours faster by |")
print("| --- | --- | --- | --- |")
print(f"| braille engine (event-driven, stepped) | {ours_infer['ms_per_sample']:.3f} | {ours_infer['us_per_input_event']:.3f} | |")
for fw in ("torch", "snntorch", "norse"):
    r = peers.get(("infer", fw))
    if r:
        print(f"| {names[fw]} | {r['per_sample_ms']:.3f} | {r['us_per_input_event']:.3f} | {r['per_sample_ms'] / ours_infer['ms_per_sample']:.1f}x |")
print("\n| conv SNN training step, batch 32 (forward, BPTT, Adam) | ms | ours relative |")
print("| --- | --- | --- |")
print(f"| braille (burn flex) | {ours_train['ms_per_train_step']:.1f} | |")
for fw in ("torch", "snntorch", "norse"):
    r = peers.get(("train", fw))
    if r:
        ratio = ours_train["ms_per_train_step"] / r["median_ms"]
        print(f"| {names[fw]} | {r['median_ms']:.1f} | {ratio:.1f}x slower |" if ratio >= 1 else f"| {names[fw]} | {r['median_ms']:.1f} | {1 / ratio:.1f}x faster |")
print(f"\nsynaptic events per sample (ours): {ours_infer['synops_per_sample']:.0f}; input events per sample: {ours_infer['input_events_per_sample']:.0f}")
