#!/usr/bin/env bash
# The shipped SNNs retrained to export to NIR as trained: every recipe exactly as shipped
# (scripts/train_icub.sh, table1.sh, words.sh) with one change, hidden neurons that reset to zero
# (NIR's reset to v_reset) instead of by subtraction, which NIR cannot write. Models go to
# models/nir/ under the shipped names; their histories to docs/results/nir/. The comparison with
# the subtracting models on the same tests: docs/results/nir/faithful.md (scripts/nir_report.sh).
# About 40 minutes on two cores.
# --trainer dense: the shipped models were trained with burn's autodiff, before the sparse trainer
# became the default (2026-11-25; docs/results/trainers.md compares the two).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
mkdir -p models/nir docs/results/nir
for set in raw1350 th10; do
  $b train --trainer dense --data "data/icub_braille/$set" --recipe "$set" --reset zero \
    --out "models/nir/snn-$set.safetensors" --history "docs/results/nir/snn_${set}_history.json" --force --quiet
done
for recipe in chars words segment; do
  $b train --trainer dense --arch snn --recipe "$recipe" --realism clean --reset zero \
    --out "models/nir/snn-$recipe.safetensors" --history "docs/results/nir/snn_${recipe}_history.json" --force --quiet
done
