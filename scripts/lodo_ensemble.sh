#!/usr/bin/env bash
# Issue #51, the third leave-one-dataset-out decision (2026-11-30, rule in
# docs/log/tactile-2026-11-30.md): seed ensembles. For raw1350, th10 and the simulated taxels, the
# headline search's final recipe (read from its final model) is trained again on the search's
# hold-out split (20% of the training split, seed 1), seeds 1-3; each member and their ensemble
# (`braille ensemble`) are scored on the hold-out. Writes
# docs/results/search/lodo-ensemble-2026-11-30/validation.jsonl (members in target/, not kept).
# With `--test NAME...`: the ensembles of those datasets' headline final models score the test
# split (one read each), appended to test.jsonl there.
# The taxel set is `target/sim-taxels` (`bash scripts/search_taxels.sh --current` makes it).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
out=docs/results/search/lodo-ensemble-2026-11-30
work=target/lodo-ensemble
mkdir -p "$out" "$work"
declare -A data=([raw1350]=data/icub_braille/raw1350 [th10]=data/icub_braille/th10 [taxels]=target/sim-taxels)
declare -A finals=([raw1350]=models/search/raw1350-warmup [th10]=models/search/th10-warmup [taxels]=models/search/sim-taxels-2026-11-28)
members() { echo "$1.safetensors $1.seed2.safetensors $1.seed3.safetensors"; }
score() { # dataset model split -> one JSON line
  local acc
  acc=$($b eval --data "${data[$1]}" --model "$2" --split "$3" --val-fraction 0.2 --val-seed 1 --json | tr -d '\n')
  echo "{\"dataset\":\"$1\",\"model\":\"$2\",\"split\":\"$3\",\"eval\":$acc}"
}
if [[ "${1:-}" == "--test" ]]; then
  shift
  for name in "$@"; do
    f=${finals[$name]}
    # shellcheck disable=SC2046
    $b ensemble $(for m in $(members "$f"); do echo --model "$m"; done) --out "$work/$name-final-ensemble.safetensors" --force
    score "$name" "$work/$name-final-ensemble.safetensors" test >> "$out/test.jsonl"
  done
  exit 0
fi
: > "$out/validation.jsonl"
for name in raw1350 th10 taxels; do
  f=${finals[$name]}
  # the final recipe as its model recorded it
  python3 scripts/recipe_of.py "$f.safetensors" > "$work/$name-recipe.json"
  ms=()
  for s in 1 2 3; do
    m=$work/$name-member$s.safetensors
    $b train --data "${data[$name]}" --recipe "$work/$name-recipe.json" --seed $s --val-fraction 0.2 --val-seed 1 \
      --out "$m" --quiet --force > "$work/$name-member$s.log"
    ms+=(--model "$m")
    score "$name" "$m" validation >> "$out/validation.jsonl"
  done
  $b ensemble "${ms[@]}" --out "$work/$name-ensemble.safetensors" --force
  score "$name" "$work/$name-ensemble.safetensors" validation >> "$out/validation.jsonl"
done
