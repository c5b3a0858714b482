#!/usr/bin/env bash
# The chip models (models/icub/chip/, models/$REALISM/chip/), each within a chip's rules (`braille export --target`,
# docs/nir.md), trained by a named recipe (experiments/src/train/recipe.rs):
# - xylo-braille7: the NIR paper's seven Braille letters on the real iCub recordings (raw1350),
#   12 inputs, 256 CubaLIF, 7 leaky-integrator outputs (Xylo: 16 inputs, 1000 hidden, 8 outputs);
# - speck-chars: a convolutional IF character classifier with sum pooling on SIMULATED windows
#   (Speck: IF neurons, convolutions, sum pooling, nine cores' memory).
# - qat/speck-chars-seed{1,2,3}: speck-chars fine-tuned for Speck (quantisation-aware, `--chip speck` on the
#   dense trainer: every forward pass Sinabs's model of the chip in float units, 8-bit weights at one scale per
#   core, the threshold at that scale, several spikes per step), 15 epochs (half the recipe's, as for Xylo), one
#   per fine-tuning seed (the validation hold-out stays the float model's, seed 1); since 2026-11-30 on training
#   scans from sensor builds 1-24 at a tenth of the recipe's learning rate (chosen on held-out builds 53-60,
#   docs/log/chips-2026-11-30.md; `clean` has one build and keeps the recipe's); about 5 minutes each.
# - qat/xylo-braille7-seed{1,2,3}: xylo-braille7 fine-tuned for Xylo (quantisation-aware, `--chip xylo`:
#   Xylo's decays and reset, every forward pass in Xylo's arithmetic), 30 epochs (half the recipe's, not
#   tuned), one per fine-tuning seed (the shuffling; the validation hold-out stays the float model's, seed 2);
#   about 15 s each.
# - icub/nir/qat/snn-raw1350-seed{1,2,3}: the raw1350 twin (models/icub/nir/, scripts/train_nir.sh) fine-tuned
#   for Loihi 2 (quantisation-aware, `--chip loihi2` on the dense trainer: the weights on Lava's 8-bit grid at
#   the mapper's scale and exponents, the integer threshold, 12-bit decays) by the twin's own recipe, with no
#   dropout (the chip as it is), 30 epochs (half the recipe's, as for Xylo, not tuned), one per fine-tuning seed
#   (validation hold-out seed 2).
#   `--loihi2-qat-only` runs only these.
# Then the chip table and the cost of the faithful export: `braille report chip`
# (docs/results/chips.md). About 40 minutes on two cores (the SIMULATED model alone about 15).
# --trainer dense: the shipped models were trained with burn's autodiff, before the sparse trainer
# became the default (2026-11-25; docs/results/trainers.md compares the two).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
# REALISM=clean|nominal|harsh (default nominal): the preset of the SIMULATED model's scans, which
# goes to models/$REALISM/chip/; `--speck-qat-only` only fine-tunes the Speck model; `--simulated-only` leaves the Xylo model
# (real recordings) as it is.
realism="${REALISM:-nominal}"
sim="models/$realism/chip"
hist="docs/results/$realism/chip"
mkdir -p models/icub/chip docs/results/icub/chip "$sim" "$hist"
mkdir -p models/icub/nir/qat
if [[ "${1:-}" != "--simulated-only" && "${1:-}" != "--speck-qat-only" ]]; then
  # the twin's own recipe, as its file records it
  python3 scripts/recipe_of.py models/icub/nir/snn-raw1350.safetensors > docs/results/icub/nir/snn_raw1350_recipe.json
  for seed in 1 2 3; do
    $b train --trainer dense --data data/icub_braille/raw1350 --recipe docs/results/icub/nir/snn_raw1350_recipe.json \
      --dropout 0 --chip loihi2 --init models/icub/nir/snn-raw1350.safetensors --epochs 30 --seed "$seed" \
      --val-fraction 0.1 --val-seed 2 \
      --out "models/icub/nir/qat/snn-raw1350-seed$seed.safetensors" \
      --history "docs/results/icub/nir/qat_snn_raw1350_seed${seed}_history.json" --force --quiet
  done
fi
if [[ "${1:-}" == "--loihi2-qat-only" ]]; then
  [[ "${2:-}" == "--no-report" ]] || $b chip-report --realism "$realism" --out docs/results
  exit 0
fi
if [[ "${1:-}" != "--simulated-only" && "${1:-}" != "--speck-qat-only" ]]; then
  $b train --trainer dense --data data/icub_braille/raw1350 --recipe xylo --out models/icub/chip/xylo-braille7.safetensors \
    --history docs/results/icub/chip/xylo_braille7_history.json --force --quiet
  mkdir -p models/icub/chip/qat
  for seed in 1 2 3; do
    $b train --data data/icub_braille/raw1350 --recipe xylo --chip xylo --init models/icub/chip/xylo-braille7.safetensors \
      --epochs 30 --seed "$seed" --val-seed 2 --out "models/icub/chip/qat/xylo-braille7-seed$seed.safetensors" \
      --history "docs/results/icub/chip/qat_xylo_braille7_seed${seed}_history.json" --force --quiet
  done
fi
if [[ "${1:-}" != "--speck-qat-only" ]]; then
  $b train --trainer dense --arch snn --recipe speck --realism "$realism" --out "$sim/speck-chars.safetensors" \
    --history "$hist/speck_chars_history.json" --force --quiet
fi
mkdir -p "$sim/qat"
more_builds=(--train-builds 1-24 --lr 2e-4)
[[ "$realism" == clean ]] && more_builds=()
for seed in 1 2 3; do
  $b train --trainer dense --arch snn --recipe speck --realism "$realism" --chip speck --init "$sim/speck-chars.safetensors" \
    --epochs 15 --seed "$seed" --val-seed 1 "${more_builds[@]}" --out "$sim/qat/speck-chars-seed$seed.safetensors" \
    --history "$hist/qat_speck_chars_seed${seed}_history.json" --force --quiet
done
if [[ "${1:-}" != "--no-report" && "${2:-}" != "--no-report" ]]; then
  $b chip-report --realism "$realism" --out docs/results
fi
