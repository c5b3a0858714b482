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
cargo build --release --quiet
b=target/release/braille
[[ -d target/sim-taxels ]] || $b sim-dataset --out target/sim-taxels
data_of() {
  case $1 in
    taxels) echo target/sim-taxels ;;
    raw1350 | th10) echo "data/icub_braille/$1" ;;
    *) echo "unknown dataset $1 (raw1350, th10 or taxels)" >&2; exit 2 ;;
  esac
}
if [[ "${1:-}" == "--search" ]]; then
  d=${2:?--search needs a dataset: raw1350, th10 or taxels}
  data=$(data_of "$d")
  name=$d trials=16
  [[ $d == taxels ]] && name=sim-taxels
  [[ $d == th10 ]] && trials=12
  for mode in exact truncated; do
    cutoff=() suffix=-stretch
    [[ $mode == exact ]] && cutoff=(--gradient-cutoff 0) suffix=-stretch-exact
    $b train --data "$data" --search --search-trials $trials --seeds 3 --stretch 0.1 "${cutoff[@]}" \
      --out "models/search/$name$suffix.safetensors" --search-dir "docs/results/search/$name$suffix" --quiet --force
  done
  exit 0
fi
out=docs/results/search/lodo-2026-12-01
mkdir -p "$out"
for d in raw1350 th10 taxels; do
  tmp=$(mktemp -d)
  $b train --data "$(data_of $d)" --search --search-trials 1 --seeds 1 --stretch 0.1 \
    --search-dir "$tmp/search" --out "$tmp/model.safetensors" --quiet
  cp "$tmp/search/search.md" "$out/$d-stretch.md"
  rm -rf "$tmp"
done
