#!/usr/bin/env bash
# The validation-driven search (issue #24) on both iCub sets, with no hand-chosen flag: the
# recipe derived from each folder, at most 16 trials (no trial starts after 30 or 45 minutes) on a 20% hold-out of the
# training split, then the winner retrained on the whole training split with seeds 1-3, whose test
# accuracy is looked at once (--eval-test). Writes models/search/ and docs/results/search/, then
# the floors beside them. About 35 (raw1350) and 75 (th10) minutes on one core each; the two run
# side by side here.
# --trainer dense: the shipped models were trained with burn's autodiff, before the sparse trainer
# became the default (2026-11-25; docs/results/trainers.md compares the two).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
mkdir -p models/search docs/results/search
$b train --trainer dense --data data/icub_braille/raw1350 --search --search-trials 16 --budget-min 30 --seeds 3 --eval-test \
  --out models/search/raw1350.safetensors --search-dir docs/results/search/raw1350 --quiet --force &
$b train --trainer dense --data data/icub_braille/th10 --search --search-trials 16 --budget-min 45 --seeds 3 --eval-test \
  --out models/search/th10.safetensors --search-dir docs/results/search/th10 --quiet --force &
wait
for d in raw1350 th10; do
  $b baselines --data data/icub_braille/$d --eval-test > docs/results/search/$d/baselines.md
done
