#!/usr/bin/env python3
"""The table of `scripts/bench_models.sh`'s runs (JSON Lines from `braille bench --model --json`)."""
import json
import sys

rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
print("# `braille bench --model`: any model on any events\n")
print("Regenerate: `bash scripts/bench_models.sh` (on an idle machine). Per-event latency: one stream, every push timed")
print("(the clock's own cost included, shown); stepped mode charges a step's work to the push that opens the next step.")
print("Input events per second: one stream untimed, and two streams on two threads (scaling = their rate over one stream's).\n")
print("| model | mode | input | events / sample | SynOps / sample | spikes / sample | accuracy | p50 ns | p99 ns | p99.9 ns | max ns | clock ns | M events/s, 1 stream | 2 streams: M events/s (scaling) | Loihi nJ / sample |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for r in rows:
    l = r["latency"]
    two = r["scaling"][-1]
    acc = f"{100 * r['accuracy']:.2f}%" if r.get("accuracy") is not None else ""
    print(f"| `{r['model'].split('/')[-1]}` ({r['source'].replace('_', ' ')}, dt {r['dt_us']} us) | {r['mode'].lower()} | {r['input'].split('/')[-1]} | "
          f"{r['input_events_per_sample']:.1f} | {r['synops_per_sample']:.0f} | {r['spikes_per_sample']:.1f} | {acc} | "
          f"{l['p50_ns']:.0f} | {l['p99_ns']:.0f} | {l['p999_ns']:.0f} | {l['max_ns']:.0f} | {r['clock_overhead_ns']:.0f} | "
          f"{r['input_events_per_s'] / 1e6:.3f} | {two['input_events_per_s'] / 1e6:.3f} ({two['speedup']:.2f}x) | {r['energy'][0]['nj_per_sample']:.1f} |")
