#!/usr/bin/env bash
# Issue #51: the evidence for the leave-one-dataset-out decision on successive halving (rule in
# docs/log/tactile-2026-12-01.md): each dataset's truncated-gradient search with --search-halving,
# at the budget of its search without it (16 trials; th10 12), validation only (final models
# trained, the test split not read). Logs in docs/results/search/{raw1350,th10,sim-taxels}-halving,
# where `bash scripts/lodo_candidate.sh --search DATASET halving -- --search-halving` finds them.
#   bash scripts/lodo_halving.sh [DATASET...]     (default: raw1350 th10 taxels, in that order)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
[[ -d target/sim-taxels ]] || $b sim-dataset --out target/sim-taxels
sets=("$@")
[[ ${#sets[@]} -gt 0 ]] || sets=(raw1350 th10 taxels)
for d in "${sets[@]}"; do
  case $d in
    raw1350) data=data/icub_braille/raw1350 name=raw1350 trials=16 ;;
    th10) data=data/icub_braille/th10 name=th10 trials=12 ;;
    taxels) data=target/sim-taxels name=sim-taxels trials=16 ;;
    *) echo "unknown dataset $d (raw1350, th10 or taxels)" >&2; exit 2 ;;
  esac
  $b train --data "$data" --search --search-halving --search-trials $trials --seeds 3 \
    --out "models/search/$name-halving.safetensors" --search-dir "docs/results/search/$name-halving" --quiet --force
done
