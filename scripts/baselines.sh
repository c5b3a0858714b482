#!/usr/bin/env bash
# The conventional side on tactile data (issue #51): `braille baselines --search --eval-test` on
# raw1350, th10 and the SIMULATED taxel set, each with a 60-minute budget: the linear floors and
# a GRU, an LSTM and a temporal CNN over the binned events, each network chosen on the SNN
# search's validation hold-out from 4 trials (bins of 20 or 50 ms, two sizes) and retrained on
# the whole training split with seeds 1-3, whose test accuracy is looked at once. Then the
# side-by-side report with the SNN search's models (`braille report tactile`).
# 2026-11-28: the three ran side by side on two cores (so each had about two thirds of a core;
# the budget is wall time, and it bound on th10). The taxel set is regenerated (about 3 minutes),
# not committed.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
$b sim-dataset --out target/sim-taxels --force
for d in data/icub_braille/raw1350 data/icub_braille/th10 target/sim-taxels; do
  $b baselines --data "$d" --search --eval-test --budget-min 60 --quiet --force \
    --out "docs/results/baselines/$(basename "$d")" > /dev/null &
done
wait
$b tactile-report
