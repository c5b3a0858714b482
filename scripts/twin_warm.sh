#!/usr/bin/env bash
# #50: twins fine-tuned from the subtracting headlines (the rule: docs/log/chips-2026-12-02.md).
# Per dataset: the headline search's chosen trial, trained by its own recipe (the 20% hold-out
# of seed 1, seeds 1-3) and then fine-tuned with reset to zero by the same recipe (`--init`,
# `--reset zero`); its score, the search's (the mean validation accuracy of the last 5 epochs
# run, over the three seeds), against the twin search's winner on the same hold-out. Only when
# it is higher are the final headline models fine-tuned the same way on the whole training split
# and scored once on the test split (`--eval-test`). Writes docs/results/twin-warm/ and, in that
# case, models/search/{raw1350,th10}-zero-warm{,.seed2,.seed3}.safetensors.
# About 10 (raw1350) and 25 (th10) minutes on two cores; what is written is not run again.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
out=docs/results/twin-warm
mkdir -p "$out" models/search

# trial_recipe, above_twin
source scripts/twin_lib.sh

run() { # name data search-log trial twin-score headline-model
  local name=$1 data=data/icub_braille/$2 log=$3 trial=$4 twin=$5 head=$6 d=$out/$1
  mkdir -p "$d"
  trial_recipe "$log" "$trial" "$d/trial-recipe.json"
  for k in 1 2 3; do
    [[ -f $d/sub-$k.safetensors ]] || $b train --data "$data" --recipe "$d/trial-recipe.json" --seed "$k" --quiet \
      --out "$d/sub-$k.safetensors" --history "$d/sub-$k.json" --force
    [[ -f $d/warm-$k.safetensors ]] || $b train --data "$data" --recipe "$d/trial-recipe.json" --seed "$k" --quiet \
      --reset zero --init "$d/sub-$k.safetensors" --out "$d/warm-$k.safetensors" --history "$d/warm-$k.json" --force
  done
  if above_twin "$name" "$d" "$twin" "subtracting trial (seeds 1-3)" sub "fine-tuned with reset to zero " warm; then
    for k in 1 2 3; do
      local src=models/search/$head.safetensors dst=models/search/$name-zero-warm.safetensors
      [[ $k == 1 ]] || { src=models/search/$head.seed$k.safetensors; dst=models/search/$name-zero-warm.seed$k.safetensors; }
      python3 scripts/recipe_of.py "$src" > "$d/final-recipe-$k.json"
      [[ -f $dst ]] || $b train --data "$data" --recipe "$d/final-recipe-$k.json" --seed "$k" --quiet \
        --reset zero --init "$src" --eval-test --out "$dst" --history "$d/final-$k.json" 2>&1 | tee "$d/final-$k.log"
    done
  fi
}

run raw1350 raw1350 docs/results/search/raw1350-stepscale/truncated/trials-0-of-1.jsonl 16 0.984877 raw1350-stepscale
run th10 th10 docs/results/search/th10-warmup/trials-0-of-1.jsonl 9 0.762423 th10-warmup
