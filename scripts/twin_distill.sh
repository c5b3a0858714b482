#!/usr/bin/env bash
# #50: twins that reset to zero distilled from the subtracting headlines (`braille train
# --distill-from`, Hinton et al. 2015: half the loss the cross-entropy against the label, half the
# divergence from the teacher's logits softened at temperature 4); the rule is written in
# docs/log/chips-2026-12-04.md before the run.
# Per dataset, on the search's hold-out (20% of the training split, seed 1): teachers are the
# headline search's chosen trial trained by its recipe (seeds 1-3, as scripts/twin_warm.sh trains
# them); students the twin search's chosen trial, seed k taught by teacher k. Their score, the
# search's (each seed's mean validation accuracy over its last 5 epochs, then the mean), against
# the twin search's winner on the same hold-out. Only when it is higher are the twins' final
# recipes trained again on the whole training split, seed k taught by the headline's final model
# of seed k, and scored once on the test split (`--eval-test`). Writes docs/results/twin-distill/
# (models of the validation stage in target/twin-distill/, not committed) and, in that case,
# models/search/{raw1350,th10}-zero-distill{,.seed2,.seed3}.safetensors.
# About 20 (raw1350) and 15 (th10) minutes on two cores; what is written is not run again.
# ENSEMBLE=1 (the second rule, docs/log/chips-2026-12-04.md): every student taught by the three
# teachers at once as an ensemble (the headline's three final models at the final stage); the
# same teachers, written to docs/results/twin-distill-ensemble/ and
# models/search/NAME-zero-distill-ensemble*.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
ens=${ENSEMBLE:-0} kind=distill
[[ $ens == 1 ]] && kind=distill-ensemble
out=docs/results/twin-$kind
mkdir -p "$out" models/search
source scripts/twin_lib.sh
distill=(--distill-weight 0.5 --distill-temperature 4)
# the teachers of seed k: its own, or all three (files PREFIX{1,2,3}SUFFIX)
teachers_of() { # k prefix suffix-of-seed-1 suffix-of-seed-2 suffix-of-seed-3
  local k=$1 p=$2
  local s=("$3" "$4" "$5")
  if [[ $ens == 1 ]]; then echo "$p${s[0]},$p${s[1]},$p${s[2]}"; else echo "$p${s[k - 1]}"; fi
}

run() { # name data headline-log headline-trial twin-log twin-trial twin-score headline-model twin-model
  local name=$1 data=data/icub_braille/$2 hlog=$3 htrial=$4 tlog=$5 ttrial=$6 twin=$7 head=$8 tw=$9
  local d=$out/$name m=target/twin-distill/$name t=docs/results/twin-distill/$name
  mkdir -p "$d" "$m" "$t" "$m-$kind"
  trial_recipe "$hlog" "$htrial" "$t/teacher-recipe.json"
  trial_recipe "$tlog" "$ttrial" "$d/student-recipe.json"
  for k in 1 2 3; do
    [[ -f $m/teacher-$k.safetensors ]] || $b train --data "$data" --recipe "$t/teacher-recipe.json" --seed "$k" \
      --quiet --out "$m/teacher-$k.safetensors" --history "$t/teacher-$k.json" --force
  done
  for k in 1 2 3; do
    [[ $d == "$t" ]] || cp "$t/teacher-$k.json" "$d/teacher-$k.json"
    [[ -f $m-$kind/student-$k.safetensors ]] || $b train --data "$data" --recipe "$d/student-recipe.json" \
      --seed "$k" --quiet --distill-from "$(teachers_of "$k" "$m/teacher-" 1.safetensors 2.safetensors 3.safetensors)" \
      "${distill[@]}" --out "$m-$kind/student-$k.safetensors" --history "$d/student-$k.json" --force
  done
  if above_twin "$name" "$d" "$twin" "teachers, the headline's trial (seeds 1-3)" teacher \
    "students, the twin's trial distilled    " student; then
    for k in 1 2 3; do
      local sfx="" ; [[ $k == 1 ]] || sfx=.seed$k
      local dst=models/search/$name-zero-$kind$sfx.safetensors teach
      teach=$(teachers_of "$k" "models/search/$head" .safetensors .seed2.safetensors .seed3.safetensors)
      python3 scripts/recipe_of.py "models/search/$tw$sfx.safetensors" > "$d/final-recipe-$k.json"
      [[ -f $dst ]] || $b train --data "$data" --recipe "$d/final-recipe-$k.json" --seed "$k" --quiet \
        --distill-from "$teach" "${distill[@]}" --eval-test --out "$dst" --history "$d/final-$k.json" 2>&1 \
        | tee "$d/final-$k.log"
    done
  fi
}

case "${1:-all}" in
  raw1350 | all) run raw1350 raw1350 docs/results/search/raw1350-stepscale/truncated/trials-0-of-1.jsonl 16 \
    docs/results/search/raw1350-zero-stepscale/truncated/trials-0-of-1.jsonl 6 0.984877 raw1350-stepscale \
    raw1350-zero-stepscale ;;&
  th10 | all) run th10 th10 docs/results/search/th10-warmup/trials-0-of-1.jsonl 9 \
    docs/results/search/th10-zero-guard-exact/trials-0-of-1.jsonl 12 0.762423 th10-warmup th10-zero-guard-exact ;;
  raw1350) ;;
  *) echo "usage: $0 [raw1350|th10|all]" >&2; exit 2 ;;
esac
