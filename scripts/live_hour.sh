#!/usr/bin/env bash
# An hour of a live sensor (issue #48), SIMULATED: `braille replay --board EV` serves rows of the
# EV board one after another for STREAM_MIN minutes (default 60; `nominal`, a test sensor build,
# 16 mm/s, 1.0 mm, a second of silence between rows) at the recorded pace over TCP, and
# `braille read tcp://` (SNN, estimated timing, lexicon) reads it as it arrives; the reader's
# resident memory (VmRSS) is sampled every 10 s. Writes docs/results/live_hour.{md,json} and the
# samples (live_hour_rss.csv). The target: peak memory flat after the first minute.
#
# BRAILLE overrides the binary (a snapshot, for long runs while the tree is rebuilt).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
minutes="${STREAM_MIN:-60}"
out=docs/results
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$b" replay --board EV --stream-min "$minutes" --listen 127.0.0.1:0 --json > "$work/served.json" 2> "$work/replay.err" &
replay=$!
until grep -q "tcp://" "$work/replay.err" 2>/dev/null; do sleep 0.1; done
address=$(grep -o "tcp://[0-9.:]*" "$work/replay.err")
# the stand-in sensor simulates each row while the one before is sent; on a busy machine a row can
# take longer to simulate than the one before takes to send, and the sender falls silent meanwhile
# (its lag is in the report): wait up to two minutes before calling it stalled
"$b" read "$address" --arch snn --json --stall-timeout-s 120 > "$work/words.jsonl" &
reader=$!
start=$(date +%s)
echo "elapsed_s,rss_kb" > "$work/rss.csv"
while kill -0 "$reader" 2>/dev/null; do
  rss=$(awk '/^VmRSS:/ {print $2}' "/proc/$reader/status" 2>/dev/null || true)
  [[ -n "$rss" ]] && echo "$(( $(date +%s) - start )),$rss" >> "$work/rss.csv"
  sleep 10
done
wait "$reader"
wait "$replay"
cp "$work/rss.csv" "$out/live_hour_rss.csv"
python3 - "$work" "$out" "$minutes" "$b" <<'PY'
import json, sys
work, out, minutes, binary = sys.argv[1:]
rss = [tuple(map(int, l.split(","))) for l in open(f"{work}/rss.csv").read().splitlines()[1:]]
lines = [json.loads(l) for l in open(f"{work}/words.jsonl")]
summary, words = lines[-1], lines[:-1]
served = json.loads(open(f"{work}/served.json").read())
after = [r for t, r in rss if t >= 60]
first = [r for t, r in rss if t < 60]
mb = lambda kb: kb / 1024
res = {
    "data": "simulated (virtual Evetac) rows of EV, nominal, served over TCP at the recorded pace",
    "stream_min": float(minutes), "binary": binary, "served": served,
    "words": len(words), "stream_s": summary["stream_s"], "read_s": summary["read_s"],
    "rss_mb_first_minute_max": mb(max(first)) if first else None,
    "rss_mb_after_first_minute": {"first": mb(after[0]), "max": mb(max(after)), "last": mb(after[-1])} if after else None,
    "samples": len(rss),
    "word_latency_ms_p50": summary.get("word_latency_ms_p50"), "word_latency_ms_p99": summary.get("word_latency_ms_p99"),
}
json.dump(res, open(f"{out}/live_hour.json", "w"), indent=2)
a = res["rss_mb_after_first_minute"]
md = [f"# An hour of a live sensor (SIMULATED)", "",
      f"Regenerate: `bash scripts/live_hour.sh` (binary `{binary}`). Rows of EV (`nominal`, a test sensor build, 16 mm/s, 1.0 mm) "
      f"served for {minutes} min by `braille replay --board EV` at the recorded pace, read over TCP by `braille read tcp://` "
      "(SNN, estimated timing, lexicon); the reader's VmRSS sampled every 10 s ([samples](live_hour_rss.csv)).", "",
      "| | value |", "| --- | --- |",
      f"| stream read | {summary['stream_s']:.0f} s in {summary['read_s']:.0f} s; {len(words)} words; {served['events']} events in {served['packets']} packets, latest packet {served['max_lag_ms']:.1f} ms behind its time |",
      f"| reader RSS, first minute (max) | {res['rss_mb_first_minute_max']:.1f} MB |" if first else "| reader RSS, first minute | - |",
      f"| reader RSS after the first minute: at 1 min, max, at the end | {a['first']:.1f} / {a['max']:.1f} / {a['last']:.1f} MB |" if a else "| reader RSS after the first minute | - |",
      f"| word latency p50 / p99 (last detection arriving to the word printed, the word gap included) | {res['word_latency_ms_p50']:.0f} / {res['word_latency_ms_p99']:.0f} ms |",
      ]
open(f"{out}/live_hour.md", "w").write("\n".join(md) + "\n")
print("\n".join(md))
PY
