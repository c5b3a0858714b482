#!/usr/bin/env bash
# The UEB readers' tables (docs/braille.md), SIMULATED at $REALISM (default nominal), both
# architectures (models/$REALISM/ueb/, scripts/ueb/train.sh): `braille report words --braille
# ueb-g2`, which reads
# - cells: RCB (the 63 cells in a random order, runs of three) at 8 mm/s, 1.5 mm, 30 scans a row,
#   every printed cell scored (a scan the labeler miscounted counts its cells as errors), and the
#   cells read worst;
# - sentences: UEB-SENTENCES (24 contracted sentences no training row holds) at 8, 16 and 32 mm/s,
#   1.0 mm, estimated timing, TRIALS (default 3) scans a row: cells, and words exact and blind to
#   case and punctuation, per spelling.
# Test sensor builds and the test seed; with VALIDATION=1 the validation boards (VCB, VAL-UEB)
# scanned by the training builds, for choices. Writes docs/results/$REALISM/ueb/ueb{,_validation}.{md,json}
# and ueb{,_validation}_speed.png. BRAILLE overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/../.."
realism="${REALISM:-nominal}"
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
extra=()
if [[ -n "${VALIDATION:-}" ]]; then extra=(--validation); fi
$b words-report --braille ueb-g2 --realism "$realism" --cell-trials 30 --speeds 8,16,32 --trials "${TRIALS:-3}" \
  "${extra[@]}"
