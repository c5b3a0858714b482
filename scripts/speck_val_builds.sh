#!/usr/bin/env bash
# What Speck's arithmetic costs the character model on sensor builds never trained or tested on
# (SIMULATED, `nominal`; docs/chips.md, "Over sensor builds never trained or tested on"):
# 1. the shipped float model, plain quantisation and the shipped fine-tuned models
#    (those of 2026-11-28, models/nominal/chip/qat-2026-11-28/, checkpoints chosen on a hold-out of the training windows), build by
#    build on the VAL board scanned by builds 51-60 -> docs/results/nominal/chip/speck_builds.md;
# 2. the same fine-tuning with checkpoints chosen on the VAL board scanned by the validation builds
#    51 and 52 (`--val-builds validation`) -> models/nominal/chip/qat-val-builds/, read on builds
#    53-60 (those that chose nothing) -> docs/results/nominal/chip/speck_builds_qat_val_builds.md.
# The test builds are not read. About 25 minutes on two cores (`--tables-only`: 4 minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p braille
cargo build --release --quiet -p experiments --example speck_builds
out=docs/results/nominal/chip
target/release/examples/speck_builds 10 51 60 models/nominal/chip/qat-2026-11-28 > "$out/speck_builds.md"
if [[ "${1:-}" != "--tables-only" ]]; then
  for seed in 1 2 3; do
    target/release/braille train --trainer dense --arch snn --recipe speck --realism nominal --chip speck \
      --init models/nominal/chip/speck-chars.safetensors --epochs 15 --seed "$seed" --val-seed 1 --val-builds validation \
      --out "models/nominal/chip/qat-val-builds/speck-chars-seed$seed.safetensors" \
      --history "$out/qat_val_builds_speck_chars_seed${seed}_history.json" --force --quiet
  done
fi
target/release/examples/speck_builds 10 53 60 models/nominal/chip/qat-val-builds > "$out/speck_builds_qat_val_builds.md"
