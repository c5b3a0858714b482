#!/usr/bin/env bash
# Trains the shipped ResNet (lite preset, NormAug) on SIMULATED scans of the SAB and UN boards at
# 8 mm/s and 1.5 mm (the paper's protocol), 40 scans per board row. Seeded. About 15 minutes on
# two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
mkdir -p models docs
target/release/braille train --arch resnet --preset lite --aug normaug --trials 40 --epochs 30 --lr 1e-3 \
  --seed 1 --out models/resnet-lite-normaug.safetensors --history docs/resnet_lite_normaug_history.json \
  --force --quiet
