#!/usr/bin/env bash
# Our ResNet presets (the shipped `nominal` model files: tiny, the segmentation network; lite, the
# Table I classifier; paper, ResNet-34) against the same architecture in plain PyTorch
# (resnet.py, rebuilt from learn/src/resnet/dense.rs, its batch norm folded into the convolutions as
# ours is), in one run on one machine, each at batch 1 on one
# thread and at batch 32 on THREADS threads (torch.set_num_threads for PyTorch, the bench's pool
# for ours). Ours runs twice per preset: on windows with a character window's share of non-zero
# cells (DENSITY, 0.02; our stem then scatters the non-zero inputs: less work than PyTorch's dense
# convolution) and on fully dense windows (density 1: the same work as PyTorch's); burn's `flex`
# backend is timed in the same bench call. Appends JSON lines to OUT (default resnet_results.jsonl)
# and prints the table (resnet_table.py), which docs/results/peers_resnet.md holds.
#
# Setup once: see compare.sh (a venv with torch). Run (about 5 minutes): `bash scripts/peers/resnet.sh
# [PYTHON] [OUT.jsonl]`.
set -euo pipefail
cd "$(dirname "$0")"
PY=${1:-./venv/bin/python}
OUT=${2:-resnet_results.jsonl}
THREADS=${THREADS:-2}
DENSITY=${DENSITY:-0.02}
(cd ../.. && cargo build --release --quiet)
b=../../target/release/braille
: > "$OUT"
echo "# $(date -u +%Y-%m-%dT%H:%MZ) threads=$THREADS cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) loadavg at start: $(cat /proc/loadavg)" >> "$OUT"
for pair in tiny:resnet-tiny-segment lite:resnet-lite-normaug paper:resnet-paper-normaug; do
  preset=${pair%%:*}
  model=../../models/nominal/${pair#*:}.safetensors
  samples=64; repeats=7; runs=200
  if [[ $preset == paper ]]; then samples=32; repeats=3; runs=30; fi
  for density in "$DENSITY" 1; do
    "$b" bench --model "$model" --batch 32 --threads "$THREADS" --samples "$samples" --repeats "$repeats" \
      --density "$density" --json | python3 -c "import json,sys; d=json.load(sys.stdin); d['preset']='$preset'; print(json.dumps(d))" >> "$OUT"
  done
  input=$(python3 -c "import json; print(','.join(map(str, [json.loads(l) for l in open('$OUT') if l.startswith('{')][-1]['input'])))")
  "$PY" resnet.py --preset "$preset" --input "$input" --density "$DENSITY" --batch 1 --threads 1 --runs "$runs" >> "$OUT"
  "$PY" resnet.py --preset "$preset" --input "$input" --density "$DENSITY" --batch 32 --threads "$THREADS" --runs $((runs / 10 + 3)) --warmup 2 >> "$OUT"
done
echo "# loadavg at end: $(cat /proc/loadavg)" >> "$OUT"
python3 resnet_table.py "$OUT"
