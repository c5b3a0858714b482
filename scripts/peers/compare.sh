#!/usr/bin/env bash
# The peer benchmark side by side with this project's engine and trainer, in one run on one
# machine: the conv SNN of the shared peer benchmark (2x60x80 ON/OFF input, conv 5x5 s2 to 8, LIF,
# conv 3x3 s2 to 16, LIF, dense to 26, LIF; 20 steps; 1.5% of pixels active per step) in plain
# PyTorch, snnTorch and Norse (bench.py, the frameworks interleaved so machine noise hits all alike;
# its layers without bias, as ours), alternated round by round with `braille bench` (the event-driven engine,
# batch 1, and 1 to THREADS streams at once against the peers' batch 32) and `braille bench --train` (BPTT + Adam, batch 32, with the sparse trainer, exact and
# truncated, and with burn), every side on the same THREADS (torch.set_num_threads for the
# peers, RAYON_NUM_THREADS for ours); prints the ratios as Markdown, the like-for-like one
# (exact gradients) first.
#
# Setup once (several GB; PyPI's torch is a CUDA build that runs on the CPU):
#     python3 -m venv venv && ./venv/bin/pip install torch snntorch norse
# Run (about 2 minutes a round, PAIRS rounds, 5 by default): `bash scripts/peers/compare.sh [PYTHON]
# [OUT.jsonl]`
set -euo pipefail
cd "$(dirname "$0")"
PY=${1:-./venv/bin/python}
OUT=${2:-results.jsonl}
THREADS=${THREADS:-2}
PAIRS=${PAIRS:-5}
(cd ../.. && cargo build --release --quiet)
: > "$OUT"
echo "# $(date -u +%Y-%m-%dT%H:%MZ) threads=$THREADS pairs=$PAIRS loadavg at start: $(cat /proc/loadavg)" >> "$OUT"
# every JSON line of a command, tagged with its round
tag() { python3 -c "import json,sys
for l in sys.stdin.read().replace('\n', ' ').replace('} {', '}\n{').splitlines():
    l = l.strip()
    if l.startswith('{'):
        d = json.loads(l); d['round'] = $1; print(json.dumps(d))"; }
# Rounds interleaved, A B A B: in each the peers then ours, for inference at batch 1 on one
# thread (our engine runs a sample on one thread, so the peers get one too) and for the training
# step on THREADS threads, so that the host's drift falls on both sides alike; the ratios are
# taken round by round and their median and range printed. The first round also times
# throughput on every thread: the peers at batch 32, our engine as THREADS independent streams.
for round in $(seq 1 "$PAIRS"); do
  "$PY" bench.py --threads 1 --model conv --mode infer --batch 1 --runs 100 --warmup 10 | tag "$round" >> "$OUT"
  if [[ $round == 1 ]]; then
    RAYON_NUM_THREADS=1 ../../target/release/braille bench --json --streams "$THREADS" | tag "$round" >> "$OUT"
    "$PY" bench.py --threads "$THREADS" --model conv --mode infer --batch 32 --runs 30 --warmup 3 | tag "$round" >> "$OUT"
  else
    RAYON_NUM_THREADS=1 ../../target/release/braille bench --json | tag "$round" >> "$OUT"
  fi
  "$PY" bench.py --threads "$THREADS" --model conv --mode train --batch 32 --runs 12 --warmup 2 | tag "$round" >> "$OUT"
  RAYON_NUM_THREADS="$THREADS" ../../target/release/braille bench --train --json | tag "$round" >> "$OUT"
done
echo "# loadavg at end: $(cat /proc/loadavg)" >> "$OUT"
"$PY" compare.py "$OUT"
