#!/usr/bin/env bash
# Issue #51: the evidence for the leave-one-dataset-out decision on successive halving (rule in
# docs/log/tactile-2026-12-01.md): each dataset's truncated-gradient search with --search-halving,
# at the budget of its search without it (16 trials; th10 12), validation only (final models
# trained, the test split not read): scripts/lodo_candidate.sh's truncated search, logs in
# docs/results/search/{raw1350,th10,sim-taxels}-halving, where its exact one will sit beside.
#   bash scripts/lodo_halving.sh [DATASET...]     (default: raw1350 th10 taxels, in that order)
set -euo pipefail
cd "$(dirname "$0")/.."
sets=("$@")
[[ ${#sets[@]} -gt 0 ]] || sets=(raw1350 th10 taxels)
for d in "${sets[@]}"; do
  MODES=truncated bash scripts/lodo_candidate.sh --search "$d" halving -- --search-halving
done
