#!/usr/bin/env bash
# Issue #51, the fourth leave-one-dataset-out decision (2026-11-30, rule in
# docs/log/tactile-2026-11-30.md): exact gradients (`--gradient-cutoff 0`) in the derived recipe,
# measured at the search's trial 0 on the three datasets (the runs without it:
# docs/results/search/lodo-2026-11-30/*-none.md, by scripts/lodo.sh). Writes
# docs/results/search/lodo-2026-11-30/*-exact.md; the test splits are not read.
# With `--th10-fold`: th10's own fold under Rule B (below).
# With `--search`: the headline searches of raw1350, the taxels and th10 again with exact
# gradients, for the decisions under the log's Rule B (validation only: the test splits are not
# read; final models in models/search/*-exact*, trained and not scored). About 35, 30 and 100
# minutes on two cores (2026-11-30).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
[[ -d target/sim-taxels ]] || $b sim-dataset --out target/sim-taxels
if [[ "${1:-}" == "--th10-fold" ]]; then
  # th10's own fold under Rule B (a 2026-11-30 session): augmentation (admitted for th10 by the second
  # decision) and exact gradients; its winner against th10-aug's 74.38% on validation (it won,
  # 74.74%, so its final models read the test split once: `braille eval --data
  # data/icub_braille/th10 --model models/search/th10-aug-exact{,.seed2,.seed3}.safetensors`).
  # About 105 minutes on two cores.
  $b train --data data/icub_braille/th10 --search --search-trials 12 --seeds 3 --stretch 0.1 --drop-events 0.1 \
    --gradient-cutoff 0 --out models/search/th10-aug-exact.safetensors --search-dir docs/results/search/th10-aug-exact \
    --quiet --force
  exit 0
fi
if [[ "${1:-}" == "--search" ]]; then
  $b train --data data/icub_braille/raw1350 --search --search-trials 16 --seeds 3 --gradient-cutoff 0 \
    --out models/search/raw1350-exact.safetensors --search-dir docs/results/search/raw1350-exact --quiet --force
  $b train --data target/sim-taxels --search --search-trials 16 --seeds 3 --gradient-cutoff 0 \
    --out models/search/sim-taxels-exact.safetensors --search-dir docs/results/search/sim-taxels-exact --quiet --force
  $b train --data data/icub_braille/th10 --search --search-trials 12 --seeds 3 --gradient-cutoff 0 \
    --out models/search/th10-exact.safetensors --search-dir docs/results/search/th10-exact --quiet --force
  exit 0
fi
out=docs/results/search/lodo-2026-11-30
mkdir -p "$out"
for d in raw1350 th10 taxels; do
  case $d in taxels) data=target/sim-taxels ;; *) data=data/icub_braille/$d ;; esac
  tmp=$(mktemp -d)
  $b train --data $data --search --search-trials 1 --seeds 1 --gradient-cutoff 0 \
    --search-dir "$tmp/search" --out "$tmp/model.safetensors" --quiet
  cp "$tmp/search/search.md" "$out/$d-exact.md"
  rm -rf "$tmp"
done
