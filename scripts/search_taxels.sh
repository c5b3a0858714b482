#!/usr/bin/env bash
# The search (issue #24) on a tactile dataset of another layout than the iCub sets, which no
# default was derived from: `braille sim-dataset` (SIMULATED, `nominal`: 5x4 event taxels of
# 1.2x2 mm under each Braille character of SAB for training and of RAB, scanned by other sensor
# builds, for test; speeds 10-30 mm/s, so samples last 0.29-0.84 s; 26 classes; about 280 events
# per sample), then its floors and `braille train --data DIR --search` with the defaults and no
# flag naming a setting. The dataset is regenerated (about 2 minutes), not committed. About 40
# minutes on two cores. --warmup-steps 0: the search of docs/results/search/sim-taxels ran before
# the learning-rate warm-up joined the derived recipe (2026-11-25); `--defaults` runs it with
# today's defaults, warm-up included (docs/results/search/sim-taxels-warmup, 2026-11-25).
# Both ran with a 40-minute budget that did not bind; the trial count alone (16) reproduces them
# on any machine.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
d=target/sim-taxels
if [[ "${1:-}" == "--defaults" ]]; then name=sim-taxels-warmup warmup=(); else name=sim-taxels warmup=(--warmup-steps 0); fi
l=docs/results/search/$name
mkdir -p "$l" models/search
$b sim-dataset --out $d --force
cp $d/dataset.json $l/dataset.json
$b baselines --data $d --eval-test > $l/baselines.md
$b train --data $d "${warmup[@]}" --search --search-trials 16 --seeds 3 --eval-test \
  --out models/search/$name.safetensors --search-dir $l --quiet --force
