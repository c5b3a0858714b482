#!/usr/bin/env bash
# The UEB readers' four networks (docs/braille.md), SIMULATED at $REALISM (default nominal), into
# models/$REALISM/ueb/ with their histories in docs/results/$REALISM/ueb/:
# - snn-cells, snn-segment: the `cells` and `cells-segment` recipes (experiments/src/train/recipe.rs);
# - resnet-lite-cells: the letters' ResNet recipe (scripts/words.sh) on the SNN's cell boards
#   (`--braille ueb-g2`) but every cell ten times (four until 2026-11-30; the SNN's 20 read
#   fewer validation words for the ResNet, docs/log/cells-2026-11-30.md), with the SNN's sweep
#   of speeds and depths, 15 epochs as the letters' (8 until 2026-11-29;
#   docs/log/grid-2026-11-29.md), the windows scaled and augmented but not centred (`--aug
#   scaleaug`: dot 1, 2 and 3 differ by their height in the row).
# Both architectures' UEB readers share the segmentation network (snn-segment), so that the two
# classifiers read identical detections. BRAILLE overrides the binary (a snapshot, for long runs
# while the tree is rebuilt). About 60 minutes on two cores; the SNN cell classifier's training
# (512 hidden neurons) peaks at 17.5 GB of memory and takes 17 minutes.
set -euo pipefail
cd "$(dirname "$0")/../.."
realism="${REALISM:-nominal}"
models="models/$realism/ueb"; out="docs/results/$realism/ueb"
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
mkdir -p "$models" "$out"
r=(--realism "$realism" --force --quiet)
only="${1:-all}"
if [[ "$only" == all || "$only" == snn ]]; then
  $b train --arch snn --recipe cells "${r[@]}" --out "$models/snn-cells.safetensors" --history "$out/snn_cells_history.json"
  $b train --arch snn --recipe cells-segment "${r[@]}" --out "$models/snn-segment.safetensors" \
    --history "$out/snn_segment_history.json"
fi
if [[ "$only" == all || "$only" == resnet ]]; then
  $b train --arch resnet --braille ueb-g2 --preset lite --aug scaleaug --pool 2 --letter-rows 10 --words 60 --trials 5 \
    --jitter-ms 40 --train-speeds 8,16,32,48 --train-depths 1.5,1.0,0.6 --epochs 15 --lr 1e-3 --seed 1 "${r[@]}" \
    --out "$models/resnet-lite-cells.safetensors" --history "$out/resnet_lite_cells_history.json"
fi
# The shared segmentation network's operating point, chosen on VAL-UEB with both classifiers
# (docs/braille.md; since 2026-11-28; 13 minutes) and recorded in its model file, where both
# readers read it.
if [[ "$only" == all ]]; then
  $b calibrate-reader --braille ueb-g2 --realism "$realism" --models "models/$realism" --out "$out" \
    --thresholds 0.4,0.5,0.6,0.7,0.8 --min-frames 4,6,8,10,12 --write
fi
