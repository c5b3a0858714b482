#!/usr/bin/env bash
# Issue #51: the evidence for the tenth leave-one-dataset-out decision, the SNN's step in the
# search space (rule in docs/log/tactile-2026-12-01.md): raw1350's and the taxels' searches under
# the fixed rule (truncated and exact gradients, 16 trials each) with `--search-step-scale 1,2`,
# validation only (the better search's final models trained, the test split not read). th10's
# 12-trial searches never reach the step's neighbour (point 14), so they are its searches without.
# Each search starts from a copy of the same search's trials 0-13 without the step (the points the
# two share, which the code reproduces to the digit); a trial the copy does not match is trained
# again (scripts/shared_trials.py; raw1350-warmup's copy takes today's default `realism`). Logs in
# docs/results/search/{raw1350,sim-taxels}-stepscale/{truncated,exact}.
#   bash scripts/lodo_step_scale.sh [DATASET...]     (default: raw1350 taxels)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
[[ -d target/sim-taxels ]] || $b sim-dataset --out target/sim-taxels
sets=("$@")
[[ ${#sets[@]} -gt 0 ]] || sets=(raw1350 taxels)
for d in "${sets[@]}"; do
  case $d in
    raw1350) data=data/icub_braille/raw1350 name=raw1350 truncated=raw1350-warmup exact=raw1350-exact ;;
    taxels) data=target/sim-taxels name=sim-taxels truncated=sim-taxels-2026-11-28 exact=sim-taxels-exact ;;
    *) echo "unknown dataset $d (raw1350 or taxels; th10 needs no run)" >&2; exit 2 ;;
  esac
  dir=docs/results/search/$name-stepscale
  for mode in truncated exact; do
    from=docs/results/search/${!mode}/trials-0-of-1.jsonl
    mkdir -p "$dir/$mode"
    if [[ ! -e $dir/$mode/trials-0-of-1.jsonl ]]; then
      python3 scripts/shared_trials.py "$from" 14 > "$dir/$mode/trials-0-of-1.jsonl"
    fi
  done
  $b train --data "$data" --search --both-gradients --search-step-scale 1,2 --search-trials 16 --seeds 3 \
    --out "models/search/$name-stepscale.safetensors" --search-dir "$dir" --quiet --force
done
