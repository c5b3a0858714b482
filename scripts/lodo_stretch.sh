#!/usr/bin/env bash
# Issue #51, the fifth leave-one-dataset-out decision (2026-12-01, rule in
# docs/log/tactile-2026-12-01.md): time stretch 0.1 alone (`--stretch 0.1`, augmentation A's first
# half) in the derived recipe, measured at the search's trial 0 on the three datasets against
# docs/results/search/lodo-2026-11-30/*-none.md (scripts/lodo.sh). Writes
# docs/results/search/lodo-2026-12-01/*-stretch.md; the test splits are not read. About 4
# minutes on two cores.
# With `--search DATASET` (raw1350, th10 or taxels): that dataset's headline search with the
# stretch, exact gradients then truncated (validation only: final models in
# models/search/*-stretch{-exact,}*, trained and not scored).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ "${1:-}" == "--search" ]]; then
  exec bash scripts/lodo_candidate.sh --search "${2:?--search needs a dataset: raw1350, th10 or taxels}" stretch -- --stretch 0.1
fi
exec bash scripts/lodo_candidate.sh stretch 2026-12-01 -- --stretch 0.1
