#!/usr/bin/env bash
# Issue #51: the leave-one-dataset-out candidate "the SNN's step twice the derived one" (rule in
# docs/log/tactile-2026-12-01.md). The derived step is 10 ms on raw1350 and th10 and 5 ms on the
# simulated taxels, so the step is given per dataset to scripts/lodo_candidate.sh:
#   bash scripts/lodo_step.sh                  trial 0 on the three datasets (validation only)
#   bash scripts/lodo_step.sh --search DATASET  that dataset's searches with the step (validation only)
set -euo pipefail
cd "$(dirname "$0")/.."
step_of() {
  case $1 in
    raw1350 | th10) echo 20000 ;;
    taxels) echo 10000 ;;
    *) echo "unknown dataset $1 (raw1350, th10 or taxels)" >&2; exit 2 ;;
  esac
}
# th10's fold has augmentation in its recipe since the second decision (docs/log/tactile-2026-11-30.md,
# 20:24Z), so its searches with the step carry it too (models and logs named th10-aug-step2). The
# search named th10-step2 (2026-12-01, the 2026-12-01 12:56Z session) ran without it: the headline's search with the
# step alone, validation only, which serves no fold.
if [[ "${1:-}" == "--search" ]]; then
  d=${2:?--search needs a dataset: raw1350, th10 or taxels}
  if [[ $d == th10 ]]; then
    exec bash scripts/lodo_candidate.sh --search th10 aug-step2 -- --stretch 0.1 --drop-events 0.1 --dt-us "$(step_of th10)"
  fi
  exec bash scripts/lodo_candidate.sh --search "$d" step2 -- --dt-us "$(step_of "$d")"
fi
for d in raw1350 th10 taxels; do
  SETS=$d bash scripts/lodo_candidate.sh step2 2026-12-01 -- --dt-us "$(step_of $d)"
done
