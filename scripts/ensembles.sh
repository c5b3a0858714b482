#!/usr/bin/env bash
# Issue #51: seed ensembles beside the single-network SNNs (rule in docs/log/tactile-2026-12-01.md,
# written before the run). Each dataset's SNN of record (raw1350 and the taxels: their searches
# with the step, since the tenth decision on 2026-12-01, before it the exact searches; th10: the
# truncated search; docs/results/tactile.md) has its final recipe, as its
# model file records it, retrained on the whole training split with seeds 4-9, into
# models/search/ensemble-members/ (no test split read). `braille report tactile` then merges
# seeds 1-3, 4-6 and 7-9 into three ensembles (`braille ensemble`) and scores each on the test
# split. About 60 CPU-minutes, JOBS (default 2) trainings at a time; the same seeds give the same
# members bit for bit.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
[[ -d target/sim-taxels ]] || $b sim-dataset --out target/sim-taxels
declare -A data=([raw1350]=data/icub_braille/raw1350 [th10]=data/icub_braille/th10 [taxels]=target/sim-taxels)
declare -A finals=([raw1350]=raw1350-stepscale [th10]=th10-warmup [taxels]=sim-taxels-stepscale)
out=models/search/ensemble-members work=target/ensembles
mkdir -p "$out" "$work"
jobs=()
for name in raw1350 th10 taxels; do
  f=${finals[$name]}
  # the final recipe as its model recorded it
  python3 scripts/recipe_of.py "models/search/$f.safetensors" > "$work/$name-recipe.json"
  for s in 4 5 6 7 8 9; do
    m=$out/$f.seed$s.safetensors
    [[ -f $m ]] || jobs+=("$b train --data ${data[$name]} --recipe $work/$name-recipe.json --seed $s --out $m --quiet")
  done
done
printf '%s\n' "${jobs[@]}" | xargs -r -P "${JOBS:-2}" -I{} bash -c '{} > /dev/null'
