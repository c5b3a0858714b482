#!/usr/bin/env bash
# The UEB readers' tables (docs/braille.md), SIMULATED at $REALISM (default nominal), test sensor
# builds, test seed, both architectures (models/$REALISM/ueb/, scripts/ueb/train.sh):
# - cells: `braille eval chars` on RCB (the 63 cells in a random order, runs of three) at 8 mm/s,
#   1.5 mm, every printed cell scored (a scan the labeler miscounted counts its cells as errors);
# - words: `braille eval words --braille ueb-g2` on UEB-SENTENCES (24 contracted sentences no
#   training row holds) at 8, 16 and 32 mm/s, 1.0 mm, estimated timing: cells, and words exact and
#   blind to case and punctuation, per spelling.
# JSON per run in docs/results/$REALISM/ueb/, then the tables: python3 scripts/ueb/table.py.
# TRIALS (default 3) scans per row. BRAILLE overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/../.."
realism="${REALISM:-nominal}"
out="docs/results/$realism/ueb"
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
trials="${TRIALS:-3}"
mkdir -p "$out"
models="models/$realism/ueb"
for arch in snn resnet; do
  if [[ "$arch" == snn ]]; then cls="$models/snn-cells.safetensors"; else cls="$models/resnet-lite-cells.safetensors"; fi
  $b eval chars --arch "$arch" --model "$cls" --board RCB --speed 8 --depth 1.5 --trials "$((10 * trials))" \
    --realism "$realism" --json > "$out/cells_rcb_${arch}.json"
  for speed in 8 16 32; do
    $b eval words --braille ueb-g2 --arch "$arch" --board UEB-SENTENCES --speed "$speed" --depth 1.0 \
      --trials "$trials" --realism "$realism" --json > "$out/words_${arch}_v${speed}.json"
  done
done
python3 scripts/ueb/table.py "$out"
