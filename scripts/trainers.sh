#!/usr/bin/env bash
# The sparse trainer (`--trainer sparse`, the default) against burn's (`--trainer dense`, the
# reference) on the shipped recipes, seeds 1-3 each: test accuracy on the iCub raw1350 and th10
# test splits (REAL) and on the simulated characters (SIMULATED: chars-report's RAB scans at
# 1.5 mm, 30 per row), with each run's training time and peak memory. Nothing is chosen here:
# the recipes are the shipped ones, the seeds fixed, each test split scored once per run.
# Writes each run's log to docs/results/trainers/ and the table to docs/results/trainers.md
# (scripts/trainers_table.py). About 75 minutes on two cores.
#
# TRAINERS="sparse dense" and DATA="raw1350 th10 chars" pick a part; the table reads whatever
# logs are there.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
out=docs/results/trainers
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
for ds in ${DATA:-raw1350 th10 chars}; do
  for trainer in ${TRAINERS:-sparse dense}; do
    for seed in 1 2 3; do
      log="$out/$ds-$trainer-s$seed.log"
      if [[ "$ds" == chars ]]; then
        "$b" train --recipe chars --realism clean --seed "$seed" --trainer "$trainer" \
          --out "$tmp/$ds-$trainer-$seed/snn-chars.safetensors" --force --quiet 2> "$log"
        "$b" chars-report --models "$tmp/$ds-$trainer-$seed" --out "$tmp/$ds-$trainer-$seed" --depths 1.5 --trials 30 --realism clean > /dev/null
        python3 - "$tmp/$ds-$trainer-$seed/chars.json" >> "$log" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
s = next(e for e in d["entries"] if e["arch"] == "snn")["scores"][-1]
printed, depth = d["printed"][-1], d["depths_mm"][-1]
right = round(s["accuracy"] * s["n"])
print(f"test accuracy on RAB at {depth} mm of all printed (SIMULATED): {100 * right / printed:.2f}% of {printed} "
      f"({100 * s['accuracy']:.2f}% of the {s['n']} windows found)")
PY
      else
        "$b" train --data "data/icub_braille/$ds" --recipe "$ds" \
          --seed "$seed" --trainer "$trainer" --eval-test --out "$tmp/m.safetensors" --force --quiet 2> "$log"
      fi
    done
  done
done
python3 scripts/trainers_table.py > docs/results/trainers.md
