#!/usr/bin/env bash
# Where each architecture's reader abstains (issue #113; the rule in docs/protocol.md,
# "Abstention"): `braille calibrate-reader --abstain` keeps the pair's recorded operating point,
# reads the validation words and sentences (VAL-WORDS, VAL-SENTENCES; validation builds 51 and
# 52, validation seed, one scan a row) at `nominal` and `harsh` x 8-200 mm/s x 0.6-1.5 mm once,
# scores every threshold of the lexicon score per letter on those readings, and records the
# chosen one with the point in the segmentation network's model file. SIMULATED; no test board
# or build is read. Usage: bash scripts/abstention.sh MODELS_DIR OUT_DIR (the pairs that ship
# after the envelope decision). BRAILLE overrides the binary.
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ $# -ne 2 ]]; then
  echo "usage: bash scripts/abstention.sh MODELS_DIR OUT_DIR" >&2
  exit 2
fi
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
for arch in snn resnet; do
  "$b" calibrate-reader --abstain --arch "$arch" --models "$1" --out "$2" --write
done
