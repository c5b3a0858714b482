#!/usr/bin/env bash
# Leave-one-dataset-out decisions on the SNN's search (issue #51; rules in
# docs/log/tactile-2026-11-30.md, each written before its run; docs/training.md).
# This script runs the second: time stretch 0.1 and event drop 0.1 in the derived recipe, measured
# at the search's trial 0 with and without them on the three datasets (about 9 minutes on two
# cores; docs/results/search/lodo-2026-11-30/, the test splits not read), then the search of the
# dataset the rule admitted them for (th10: 28 minutes, its test split read once).
# The first (the neuron's reset as a search dimension) compares searches made elsewhere: the
# zero-reset searches of raw1350 (`scripts/search_icub.sh --twins`), th10 (`--twins-guard`) and
# the taxels (`scripts/search_taxels.sh --zero`) against the subtracting ones
# (docs/results/search/*/search.md), validation winners only.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
[[ -d target/sim-taxels ]] || $b sim-dataset --out target/sim-taxels
out=docs/results/search/lodo-2026-11-30
mkdir -p "$out"
for d in raw1350 th10 taxels; do
  case $d in taxels) data=target/sim-taxels ;; *) data=data/icub_braille/$d ;; esac
  for v in none aug; do
    extra=()
    [[ $v == aug ]] && extra=(--stretch 0.1 --drop-events 0.1)
    tmp=$(mktemp -d)
    $b train --data $data --search --search-trials 1 --seeds 1 "${extra[@]}" \
      --search-dir "$tmp/search" --out "$tmp/model.safetensors" --quiet
    cp "$tmp/search/search.md" "$out/$d-$v.md"
    rm -rf "$tmp"
  done
done
$b train --data data/icub_braille/th10 --search --search-trials 12 --seeds 3 --eval-test --stretch 0.1 --drop-events 0.1 \
  --out models/search/th10-aug.safetensors --search-dir docs/results/search/th10-aug --quiet --force
