#!/usr/bin/env bash
# The search (issue #24) on a tactile dataset of another layout than the iCub sets, which no
# default was derived from: `braille sim dataset` (SIMULATED, `nominal`: 5x4 event taxels of
# 1.2x2 mm under each Braille character of SAB for training and of RAB, scanned by other sensor
# builds, for test; speeds 10-30 mm/s, so samples last 0.29-0.84 s; 26 classes; about 280 events
# per sample), then its floors and `braille train --data DIR --search` with the defaults and no
# flag naming a setting. The dataset is regenerated (about 2 minutes), not committed. About 40
# minutes on two cores. --warmup-steps 0: the search of docs/results/search/sim-taxels ran before
# the learning-rate warm-up joined the derived recipe (2026-11-25); `--defaults` runs it with
# today's defaults, warm-up included (docs/results/search/sim-taxels-warmup, 2026-11-25).
# Both ran with a 40-minute budget that did not bind; the trial count alone (16) reproduces them
# on any machine.
# `--current` (2026-11-28, issue #51) runs the `--defaults` search again on the dataset as the
# simulator makes it today (stick-slip and per-build optics joined `nominal` on 2026-11-27, so the
# set differs from the one of 2026-11-25): docs/results/search/sim-taxels-2026-11-28, the SNN
# that `braille report tactile` puts beside the networks of scripts/baselines.sh on the same
# samples. It ran beside two of those searches on two cores (about 60 minutes).
# `--zero` (2026-11-30, #51's first leave-one-dataset-out decision) runs the `--current` search
# with neurons that reset to zero, its test split not read (docs/results/search/sim-taxels-zero;
# 16 minutes alone on two cores).
# `--twins-step` (2026-12-02, #50): the taxels' exportable twin searched as the headline is (truncated
# and exact gradients, the step at 1 and 2 times the derived one, 16 trials, 3 seeds) with reset
# to zero a fixed part of the space; the truncated search starts from sim-taxels-zero's trials
# 0-13; only the better one's final models are trained, and they read the test split once (rule
# in docs/log/chips-2026-12-02.md). A stopped run resumes from its logs.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
d=target/sim-taxels
if [[ "${1:-}" == "--twins-step" ]]; then
  [[ -d $d ]] || $b sim-dataset --out $d
  l=docs/results/search/sim-taxels-zero-stepscale
  mkdir -p "$l/truncated" "$l/exact" models/search
  cp $d/dataset.json $l/dataset.json
  [[ -e $l/truncated/trials-0-of-1.jsonl ]] \
    || python3 scripts/shared_trials.py docs/results/search/sim-taxels-zero/trials-0-of-1.jsonl 14 > "$l/truncated/trials-0-of-1.jsonl"
  $b train --data $d --reset zero --search --both-gradients --search-trials 16 --seeds 3 --eval-test \
    --out models/search/sim-taxels-zero-stepscale.safetensors --search-dir "$l" --quiet --force
  exit 0
fi
case "${1:-}" in
  --defaults) name=sim-taxels-warmup warmup=() ;;
  --current) name=sim-taxels-2026-11-28 warmup=() ;;
  --zero) name=sim-taxels-zero warmup=(--reset zero) ;;
  *) name=sim-taxels warmup=(--warmup-steps 0) ;;
esac
l=docs/results/search/$name
mkdir -p "$l" models/search
$b sim-dataset --out $d --force
cp $d/dataset.json $l/dataset.json
# the floors (with the networks: scripts/baselines.sh)
[[ "${1:-}" == "--current" || "${1:-}" == "--zero" ]] || $b baselines --data $d --eval-test > $l/baselines.md
test_read=(--eval-test)
[[ "${1:-}" == "--zero" ]] && test_read=()
$b train --data $d "${warmup[@]}" --search --search-trials 16 --seeds 3 "${test_read[@]}" \
  --out models/search/$name.safetensors --search-dir $l --quiet --force
