#!/usr/bin/env bash
# Issue #51: one leave-one-dataset-out candidate, given as `braille train` flags, measured at the
# search's trial 0 (the derived recipe, truncated gradients, seeds 1-3, scored on the search's
# validation hold-out) on raw1350, th10 and the simulated taxels; the test splits are not read.
#   bash scripts/lodo_candidate.sh NAME DATE -- FLAGS...
# writes docs/results/search/lodo-DATE/{raw1350,th10,taxels}-NAME.md, to set beside the same
# trial without the candidate (docs/results/search/lodo-2026-11-30/*-none.md). SETS (default
# "raw1350 th10 taxels") names the datasets, for a candidate whose flags differ by dataset.
#   bash scripts/lodo_candidate.sh --search DATASET NAME -- FLAGS...
# runs DATASET's headline search with the candidate, exact gradients then truncated (validation
# only: final models in models/search/{DATASET}-NAME{-exact,}*, trained and not scored).
# MODES (default "exact truncated") names the searches to run.
# The rule each decision applies is written in docs/log/ before its run.
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
  d=${2:?--search needs a dataset: raw1350, th10 or taxels} cand=${3:?and a name}
  [[ "${4:-}" == "--" ]] || { echo "flags after --" >&2; exit 2; }
  shift 4
  data=$(data_of "$d")
  name=$d trials=16
  [[ $d == taxels ]] && name=sim-taxels
  [[ $d == th10 ]] && trials=12
  for mode in ${MODES:-exact truncated}; do
    cutoff=() suffix=-$cand
    [[ $mode == exact ]] && cutoff=(--gradient-cutoff 0) suffix=-$cand-exact
    $b train --data "$data" --search --search-trials $trials --seeds 3 "$@" "${cutoff[@]}" \
      --out "models/search/$name$suffix.safetensors" --search-dir "docs/results/search/$name$suffix" --quiet --force
  done
  exit 0
fi
cand=${1:?a name for the candidate} date=${2:?the date of the decision}
[[ "${3:-}" == "--" ]] || { echo "flags after --" >&2; exit 2; }
shift 3
out=docs/results/search/lodo-$date
mkdir -p "$out"
for d in ${SETS:-raw1350 th10 taxels}; do
  tmp=$(mktemp -d)
  $b train --data "$(data_of $d)" --search --search-trials 1 --seeds 1 "$@" \
    --search-dir "$tmp/search" --out "$tmp/model.safetensors" --quiet
  cp "$tmp/search/search.md" "$out/$d-$cand.md"
  rm -rf "$tmp"
done
