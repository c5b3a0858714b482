#!/usr/bin/env bash
# The paper's Table I and depth figure on SIMULATED scans, with the SNN beside the ResNet:
# trains the ResNet lite in the four input configurations (Raw, Norm, Aug, NormAug) and the SNN
# on the same windows (SAB and UN boards, 8 mm/s, 1.5 mm, 40 scans per board row, seed 1), then
# tests every model on the same RAB scans at the paper's seven depths (`braille report chars`).
# The report also tests the word-reading classifiers (`+ words`, trained by scripts/words.sh) when
# the models folder holds them. About 60 minutes on two cores; `--report-only` skips the training.
#
# REALISM=clean|nominal|harsh picks the simulator's preset (default nominal, the published tables;
# clean is kept for regression, into models/ and docs/results/); beyond clean, models go to
# models/$REALISM/ and results to docs/results/$REALISM/, and training uses the training sensor
# builds, testing the test builds (docs/simulator.md).
# --trainer dense: the shipped models were trained with burn's autodiff, before the sparse trainer
# became the default (2026-11-25; docs/results/trainers.md compares the two).
# BRAILLE overrides the binary (a snapshot, for long runs while the tree is rebuilt).
set -euo pipefail
cd "$(dirname "$0")/.."
realism="${REALISM:-nominal}"
models="models/$realism"; out="docs/results/$realism"
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
mkdir -p "$models" "$out"
b="${BRAILLE:-target/release/braille}"
if [[ "${1:-}" != "--report-only" ]]; then
  for aug in raw norm aug normaug; do
    $b train --arch resnet --preset lite --aug "$aug" --trials 40 --epochs 30 --lr 1e-3 \
      --seed 1 --realism "$realism" --out "$models/resnet-lite-$aug.safetensors" \
      --history "$out/resnet_lite_${aug}_history.json" --force --quiet
  done
  # The SNN: 2560 inputs (the 64x80 crop pooled 2x2, ON and OFF) -> 256 LIF -> 26 leaky
  # integrators, 10 ms steps; events dropped with probability 0.3 in training (a shallower press
  # gives fewer events).
  $b train --trainer dense --arch snn --recipe chars --realism "$realism" --out "$models/snn-chars.safetensors" \
    --history "$out/snn_chars_history.json" --force --quiet
fi
$b chars-report --models "$models" --out "$out" --trials 30 --realism "$realism"
