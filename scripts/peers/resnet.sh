#!/usr/bin/env bash
# Our ResNet presets (the shipped `nominal` model files: tiny, the segmentation network; lite, the
# Table I classifier; paper, ResNet-34) against the same architecture in plain PyTorch
# (resnet.py, rebuilt from learn/src/resnet/dense.rs, its batch norm folded into the convolutions by
# torch.fx as ours is), in one run on one machine, each at batch 1 on one
# thread and at batch 32 on THREADS threads (torch.set_num_threads for PyTorch, the bench's pool
# for ours). The two sides are interleaved: PAIRS rounds (5 by default), in each round and preset
# PyTorch then ours, so the host's drift falls on both alike; the table gives each time's median
# over the rounds and each ratio's median and range, the ratio taken within its round. Ours runs twice per preset: on windows with a character window's share of non-zero
# cells (DENSITY, 0.02; our stem then scatters the non-zero inputs: less work than PyTorch's dense
# convolution) and on fully dense windows (density 1: the same work as PyTorch's); burn's `flex`
# backend is timed in the same bench call. Appends JSON lines to OUT (default resnet_results.jsonl)
# and prints the table (resnet_table.py), which docs/results/peers_resnet.md holds.
#
# Setup once: see compare.sh (a venv with torch). Run (about 2 minutes a round): `bash scripts/peers/resnet.sh
# [PYTHON] [OUT.jsonl]`.
set -euo pipefail
cd "$(dirname "$0")"
PY=${1:-./venv/bin/python}
OUT=${2:-resnet_results.jsonl}
THREADS=${THREADS:-2}
DENSITY=${DENSITY:-0.02}
PAIRS=${PAIRS:-5}
(cd ../.. && cargo build --release --quiet)
b=../../target/release/braille
: > "$OUT"
echo "# $(date -u +%Y-%m-%dT%H:%MZ) threads=$THREADS cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) pairs=$PAIRS loadavg at start: $(cat /proc/loadavg)" >> "$OUT"
# every JSON line, tagged with its preset and round
tag() { python3 -c "import json,sys
text = sys.stdin.read()
for l in [text] if text.lstrip().startswith('{\n') else text.splitlines():
    if l.strip().startswith('{'):
        d = json.loads(l); d['preset'] = '$1'; d['round'] = $2; print(json.dumps(d))"; }
pairs=(tiny:resnet-tiny-segment lite:resnet-lite-normaug paper:resnet-paper-normaug)
# each model file's input shape (C,H,W), read once
declare -A inputs
for pair in "${pairs[@]}"; do
  inputs[${pair%%:*}]=$("$b" bench --model "../../models/nominal/${pair#*:}.safetensors" --batch 1 --samples 1 --repeats 1 --json |
    python3 -c "import json,sys; print(','.join(map(str, json.load(sys.stdin)['input'])))")
done
for round in $(seq 1 "$PAIRS"); do
  for pair in "${pairs[@]}"; do
    preset=${pair%%:*}
    model=../../models/nominal/${pair#*:}.safetensors
    samples=64; repeats=7; runs=200
    if [[ $preset == paper ]]; then samples=32; repeats=3; runs=30; fi
    input=${inputs[$preset]}
    "$PY" resnet.py --preset "$preset" --input "$input" --density "$DENSITY" --batch 1 --threads 1 --runs "$runs" | tag "$preset" "$round" >> "$OUT"
    "$PY" resnet.py --preset "$preset" --input "$input" --density "$DENSITY" --batch 32 --threads "$THREADS" --runs $((runs / 10 + 3)) --warmup 2 | tag "$preset" "$round" >> "$OUT"
    for density in "$DENSITY" 1; do
      "$b" bench --model "$model" --batch 32 --threads "$THREADS" --samples "$samples" --repeats "$repeats" \
        --density "$density" --json | tag "$preset" "$round" >> "$OUT"
    done
  done
done
echo "# loadavg at end: $(cat /proc/loadavg)" >> "$OUT"
python3 resnet_table.py "$OUT"
