#!/usr/bin/env bash
# Quantisation-aware fine-tuning of the Speck character model on training scans from 24 sensor
# builds (1-24) instead of the four that trained it (SIMULATED, `nominal`; docs/chips.md, "On more
# sensor builds"; docs/log/chips-2026-11-30.md):
# A. as shipped (15 epochs, the recipe's learning rate), seeds 1-3 -> models/nominal/chip/qat-more-builds/,
#    and the float controls (the same fine-tunings as A and B without the chip, seed 1);
# B. the same at a tenth of the learning rate (2e-4) -> models/nominal/chip/qat/ (shipped since 2026-11-30,
#    chosen by this read; scripts/train_chips.sh makes the same models);
# C. B's learning rate on the training builds 1-4 alone (attribution only) -> models/nominal/chip/qat-lr2e-4/;
# each read build by build on the VAL board scanned by builds 53-60 (never trained, tested or
# used to choose a checkpoint) -> docs/results/nominal/chip/speck_builds_qat_more_builds{,_lr2e-4}.md.
# The test builds are not read. About 50 minutes on two cores (`--tables-only`: 2 minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p braille
cargo build --release --quiet -p experiments --example speck_builds
out=docs/results/nominal/chip
float=models/nominal/chip/speck-chars.safetensors
a=models/nominal/chip/qat-more-builds
b=models/nominal/chip/qat
c=models/nominal/chip/qat-lr2e-4
train() {
  target/release/braille train --trainer dense --arch snn --recipe speck --realism nominal --init "$float" \
    --epochs 15 --val-seed 1 --train-builds 1-24 --force --quiet "$@"
}
if [[ "${1:-}" != "--tables-only" ]]; then
  for seed in 1 2 3; do
    train --chip speck --seed "$seed" --out "$a/speck-chars-seed$seed.safetensors" \
      --history "$out/qat_more_builds_speck_chars_seed${seed}_history.json"
  done
  train --seed 1 --out "$a/float-control-seed1.safetensors" --history "$out/more_builds_float_control_seed1_history.json"
  for seed in 1 2 3; do
    train --chip speck --seed "$seed" --lr 2e-4 --out "$b/speck-chars-seed$seed.safetensors" \
      --history "$out/qat_speck_chars_seed${seed}_history.json"
  done
  train --seed 1 --lr 2e-4 --out "$a/float-control-lr2e-4-seed1.safetensors" \
    --history "$out/more_builds_float_control_lr2e-4_seed1_history.json"
  for seed in 1 2 3; do
    train --chip speck --seed "$seed" --lr 2e-4 --train-builds 1-4 --out "$c/speck-chars-seed$seed.safetensors" \
      --history "$out/qat_lr2e-4_speck_chars_seed${seed}_history.json"
  done
fi
target/release/examples/speck_builds 10 53 60 "$a" --control "$a/float-control-seed1.safetensors" \
  > "$out/speck_builds_qat_more_builds.md"
target/release/examples/speck_builds 10 53 60 "$b" --control "$a/float-control-seed1.safetensors" \
  > "$out/speck_builds_qat_more_builds_lr2e-4.md"
target/release/examples/speck_builds 10 53 60 "$c" > "$out/speck_builds_qat_lr2e-4.md"
target/release/examples/speck_builds 10 53 60 "$b" --control "$a/float-control-lr2e-4-seed1.safetensors" \
  > "$out/speck_builds_qat_control_lr2e-4.md"
