#!/usr/bin/env python3
"""Ratios of this project's engine and trainer against the peers, from one compare.sh run."""
import json
import sys

rows_all = [json.loads(l) for l in open(sys.argv[1] if len(sys.argv) > 1 else "results.jsonl") if l.startswith("{")]
# the single-run tables read the first round (files without rounds are one round)
rows = [r for r in rows_all if r.get("round", 1) == 1]
stamp = next((l[2:].strip() for l in open(sys.argv[1] if len(sys.argv) > 1 else "results.jsonl") if l.startswith("# 20")), "")
peers = {(r["mode"], r["fw"]): r for r in rows if "fw" in r and not (r["mode"] == "infer" and r["batch"] > 1)}
batched = {r["fw"]: r for r in rows if "fw" in r and r["mode"] == "infer" and r["batch"] > 1}
ours_infer = next(r for r in rows if "ms_per_sample" in r)
ours_train = next(r for r in rows if "sparse_exact" in r)
names = {"torch": "plain PyTorch", "snntorch": "snnTorch", "norse": "Norse"}
cpu = next((r["cpu"] for r in rows if "cpu" in r), "?")
infer_threads = next((r["threads"] for r in rows if r.get("mode") == "infer" and "threads" in r), "?")
train_threads = next((r["threads"] for r in rows if r.get("mode") == "train" and "threads" in r), "?")
bias = any(r.get("bias") for r in rows if "fw" in r)
print(f"Measured {stamp} on {cpu}. Inference: every side on {infer_threads} thread(s); training: the peers on "
      f"{train_threads} threads, ours on {ours_train.get('threads', '?')}. The peers' layers {'had' if bias else 'had no'} "
      "bias (ours have none).\n")
print("| conv SNN, batch 1 | ms / sample | us / input event | ours faster by |")
print("| --- | --- | --- | --- |")
print(f"| braille engine (event-driven, stepped) | {ours_infer['ms_per_sample']:.3f} | {ours_infer['us_per_input_event']:.3f} | |")
for fw in ("torch", "snntorch", "norse"):
    r = peers.get(("infer", fw))
    if r:
        print(f"| {names[fw]} | {r['per_sample_ms']:.3f} | {r['us_per_input_event']:.3f} | {r['per_sample_ms'] / ours_infer['ms_per_sample']:.1f}x |")
streams = ours_infer.get("streams") or []
if batched and len(streams) > 1:
    top = streams[-1]
    b = next(iter(batched.values()))
    print(f"\n| conv SNN, throughput on {b['threads']} threads | samples / s | against plain PyTorch |")
    print("| --- | --- | --- |")
    for s in streams:
        ratio = ""
        if "torch" in batched:
            ratio = f"{s['samples_per_s'] * batched['torch']['per_sample_ms'] / 1e3:.1f}x faster"
        print(f"| braille engine, {s['streams']} stream(s) at once, batch 1 each ({s['speedup']:.2f}x one stream) | {s['samples_per_s']:.0f} | {ratio} |")
    for fw in ("torch", "snntorch", "norse"):
        r = batched.get(fw)
        if r:
            print(f"| {names[fw]}, batch {r['batch']} | {1e3 / r['per_sample_ms']:.0f} | |")
    for key, what in (("register_loop", "arithmetic in vector registers, no memory"), ("cache_loop", "loads from each thread's own 1 MiB")):
        host = ours_infer.get(key) or []
        if len(host) > 1:
            rows = ", ".join(f"{h['threads']} threads {h['speedup']:.2f}x" for h in host[1:])
            print(f"\nthe host in the same rounds as the streams, {what}: {rows} one thread")
print("\n| conv SNN training step, batch 32 (forward, BPTT, Adam) | ms | spike rate per layer | against plain PyTorch |")
print("| --- | --- | --- | --- |")
torch_train = peers.get(("train", "torch"))
def against(ms):
    if not torch_train:
        return ""
    r = torch_train["median_ms"] / ms
    return f"{r:.1f}x faster" if r >= 1 else f"{1 / r:.1f}x slower"
rates = lambda rs: " / ".join(f"{100 * r:.1f}%" for r in rs)
labels = {
    "sparse_exact": "braille, sparse trainer, exact gradients (like for like)",
    "sparse": "braille, sparse trainer truncated (an approximate gradient)",
    "dense": "braille on burn (dense, autodiff)",
}
for key in ("sparse_exact", "sparse", "dense"):
    t = ours_train[key]
    print(f"| {labels[key]}: {t['trainer']} | {t['ms_per_train_step']:.1f} | {rates(ours_train['spike_rate_per_layer'])} | {against(t['ms_per_train_step'])} |")
for fw in ("torch", "snntorch", "norse"):
    r = peers.get(("train", fw))
    if r:
        print(f"| {names[fw]} | {r['median_ms']:.1f} | {rates(r['spike_rate_per_layer'])} | {against(r['median_ms']) if fw != 'torch' else ''} |")
mem = ", ".join(f"{ours_train[k]['trainer']} {ours_train[k]['peak_rss_mb']:.0f} MB" for k in ("sparse", "sparse_exact", "dense"))
print(f"\ntraining memory, peak RSS of the process while each trainer ran: {mem}", end="")
if torch_train:
    print(f"; the peers' process (all three frameworks): {torch_train['process_peak_rss_mb']:.0f} MB, {torch_train['rss_before_build_mb']:.0f} MB before building the networks")
else:
    print()
print(f"\nsparse trainer: truncation at {ours_train['gradient_cutoff']} of the surrogate's peak, gradient cosine {ours_train['truncation_cosine']:.4f} against the exact one on the first batch (whole epochs of the shipped recipes: docs/results/trainers.md) "
      f"(relative error {ours_train['truncation_relative_error']:.3f}), {100 * ours_train['kept_fraction']:.1f}% of neuron-steps kept")
print(f"\nsynaptic events per sample (ours): {ours_infer['synops_per_sample']:.0f}; input events per sample: {ours_infer['input_events_per_sample']:.0f}")

# the interleaved rounds: each ratio taken within its round, then its median and range
rounds = sorted({r["round"] for r in rows_all if "round" in r})
if len(rounds) > 1:
    import statistics
    def ratios(peer, ours):
        out = []
        for k in rounds:
            rs = [r for r in rows_all if r.get("round") == k]
            p = next((peer(r) for r in rs if "fw" in r and r["fw"] == "torch" and peer(r) is not None), None)
            o = next((ours(r) for r in rs if ours(r) is not None), None)
            if p is not None and o is not None:
                out.append(p / o)
        return out
    infer_b1 = lambda r: r["per_sample_ms"] if r.get("mode") == "infer" and r.get("batch") == 1 else None
    train = lambda r: r["median_ms"] if r.get("mode") == "train" else None
    ours_b1 = lambda r: r.get("ms_per_sample")
    exact = lambda r: r["sparse_exact"]["ms_per_train_step"] if "sparse_exact" in r else None
    trunc = lambda r: r["sparse"]["ms_per_train_step"] if "sparse" in r and "sparse_exact" in r else None
    print(f"\n{len(rounds)} rounds, each the peers then ours, the ratio (plain PyTorch's time over ours) taken within its round:\n")
    print("| | median | range | per round |")
    print("| --- | --- | --- | --- |")
    for what, rs in (("engine, batch 1, one thread: faster by", ratios(infer_b1, ours_b1)),
                     ("training step, exact gradients: PyTorch's time over ours", ratios(train, exact)),
                     ("training step, truncated (approximate) gradients: the same", ratios(train, trunc))):
        if rs:
            print(f"| {what} | {statistics.median(rs):.2f}x | {min(rs):.2f}-{max(rs):.2f}x | {', '.join(f'{r:.2f}' for r in rs)} |")
    ns = [next(r["ns_per_synop"] for r in rows_all if r.get("round") == k and "ns_per_synop" in r) for k in rounds]
    print(f"| engine alone, ns per synaptic operation | {statistics.median(ns):.3f} | {min(ns):.3f}-{max(ns):.3f} | {', '.join(f'{v:.3f}' for v in ns)} |")
