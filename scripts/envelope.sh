#!/usr/bin/env bash
# Readers trained for the whole envelope (issue #113), SIMULATED. Both architectures' pairs
# (segmentation network and classifier) are trained as the shipped `nominal` pairs are
# (scripts/words.sh: the same recipes, boards, seeds and epochs), with three changes, the same
# for both architectures so that they train on identical streams:
# - every training scan's events pass DV's noise filter as the seed's lab records through it
#   (`denoise=dv-lab`), recorded in the models so that their reader filters the same way;
# - each scan's nuisances drawn at a level of the way from `nominal` to `harsh`
#   (`train_levels=0,0.5,1`: noise, hot pixels, mount, misalignment, yaw, depth wander, print);
# - speeds over 4-200 mm/s and depths over 0.6-1.5 mm for the classifiers and the
#   segmentation networks alike.
# Checkpoints are chosen on each recipe's own validation hold-out (training builds); each pair's
# operating point is then calibrated on the validation words (VAL-WORDS, validation seed) at
# `harsh` (`braille calibrate-reader`). Then scripts/envelope_validation.sh compares them with
# the shipped pairs on the validation words, by the rule in docs/protocol.md ("Readers for the
# envelope"). No test board or build is read. About three hours on two cores (each classifier about
# 40 minutes, each segmentation network 20-40, each calibration 15-30).
# Models go to models/envelope/, histories to docs/results/envelope/. BRAILLE overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
models=models/envelope; out=docs/results/envelope
mkdir -p "$models" "$out"
envelope=(--set denoise=dv-lab --set train_levels=0,0.5,1 --set train_speeds_mm_s=4,8,16,32,64,128,200
  --set train_depths_mm=1.5,1.0,0.6)
$b train --arch snn --recipe words "${envelope[@]}" --realism nominal --out "$models/snn-words.safetensors" \
  --history "$out/snn_words_history.json" --force --quiet
$b set-band "$models/snn-words.safetensors" --rows 12,100
$b train --arch resnet --preset lite --aug normaug --pool 2 --words 0 --letter-rows 3 \
  --trials 5 --jitter-ms 40 --crop-rows 20,100 "${envelope[@]}" \
  --epochs 15 --lr 1e-3 --seed 1 --realism nominal --out "$models/resnet-lite-normaug-words.safetensors" \
  --history "$out/resnet_lite_normaug_words_history.json" --force --quiet
$b train --arch snn --recipe segment --blank-cells true "${envelope[@]}" --realism nominal \
  --out "$models/snn-segment.safetensors" --history "$out/snn_segment_history.json" --force --quiet
$b train --arch resnet --task segment --blank-cells true --preset tiny --pool 2 --aug aug --words 30 --trials 10 \
  --crop-rows 20,100 "${envelope[@]}" --epochs 8 --lr 1e-3 --seed 1 --realism nominal \
  --out "$models/resnet-tiny-segment.safetensors" --history "$out/resnet_tiny_segment_history.json" --force --quiet
for arch in snn resnet; do
  $b calibrate-reader --arch "$arch" --realism harsh --models "$models" --out "$out" --write
done
