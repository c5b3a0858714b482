#!/usr/bin/env bash
# The peer benchmark side by side with this project's engine and trainer, in one run on one
# machine: the conv SNN of the shared peer benchmark (2x60x80 ON/OFF input, conv 5x5 s2 to 8, LIF,
# conv 3x3 s2 to 16, LIF, dense to 26, LIF; 20 steps; 1.5% of pixels active per step) in plain
# PyTorch, snnTorch and Norse (bench.py, interleaved so machine noise hits all alike; its layers
# without bias, as ours, since 2026-11-26), then in `braille bench` (the event-driven engine,
# batch 1, and 1 to THREADS streams at once against the peers' batch 32) and `braille bench --train` (BPTT + Adam, batch 32, with the sparse trainer, exact and
# truncated, and with burn), every side on the same THREADS (torch.set_num_threads for the
# peers, RAYON_NUM_THREADS for ours); prints the ratios as Markdown, the like-for-like one
# (exact gradients) first.
#
# Setup once (several GB; PyPI's torch is a CUDA build that runs on the CPU):
#     python3 -m venv venv && ./venv/bin/pip install torch snntorch norse
# Run (about 2 minutes): `bash scripts/peers/compare.sh [PYTHON] [OUT.jsonl]`
set -euo pipefail
cd "$(dirname "$0")"
PY=${1:-./venv/bin/python}
OUT=${2:-results.jsonl}
THREADS=${THREADS:-2}
(cd ../.. && cargo build --release --quiet)
: > "$OUT"
echo "# $(date -u +%Y-%m-%dT%H:%MZ) threads=$THREADS loadavg at start: $(cat /proc/loadavg)" >> "$OUT"
# inference, batch 1: our engine runs a sample on one thread, so the peers get one too
"$PY" bench.py --threads 1 --model conv --mode infer --batch 1 --runs 100 --warmup 10 >> "$OUT"
# throughput on every thread: the peers at batch 32, our engine as THREADS independent streams
"$PY" bench.py --threads "$THREADS" --model conv --mode infer --batch 32 --runs 30 --warmup 3 >> "$OUT"
"$PY" bench.py --threads "$THREADS" --model conv --mode train --batch 32 --runs 12 --warmup 2 >> "$OUT"
RAYON_NUM_THREADS=1 ../../target/release/braille bench --json --streams "$THREADS" | tr -d '\n' >> "$OUT"
echo >> "$OUT"
RAYON_NUM_THREADS="$THREADS" ../../target/release/braille bench --train --json | tr -d '\n' >> "$OUT"
echo >> "$OUT"
echo "# loadavg at end: $(cat /proc/loadavg)" >> "$OUT"
"$PY" compare.py "$OUT"
