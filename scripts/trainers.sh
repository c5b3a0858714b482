#!/usr/bin/env bash
# The sparse trainer (`--trainer sparse`, the default, truncated at a cutoff of 0.01) against the
# same trainer with exact gradients (`exact`: `--gradient-cutoff 0`) and burn's (`--trainer
# dense`, the reference) on the shipped recipes, seeds 1-3 each: test accuracy on the iCub raw1350 and th10
# test splits (REAL) and on the simulated characters (SIMULATED: chars-report's RAB scans at
# 1.5 mm, 30 per row), with each run's training time and peak memory. Nothing is chosen here:
# the recipes are the shipped ones, the seeds fixed, each test split scored once per run.
# Writes each run's log to docs/results/trainers/ and the table to docs/results/trainers.md
# (scripts/trainers_table.py). About 75 minutes on two cores.
#
# The truncated runs also compare every batch's gradient with the exact one on the first and
# the last epoch (`--check-truncation`: cosine and relative error in the log; the weights trained
# are the same as without it).
# TRAINERS="sparse exact dense" and DATA="raw1350 th10 chars" pick a part; the table reads
# whatever logs are there.
set -euo pipefail
cd "$(dirname "$0")/.."
# BRAILLE=path runs that binary (a snapshot while the tree changes); otherwise it is built here.
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
out=docs/results/trainers
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
for ds in ${DATA:-raw1350 th10 chars}; do
  for trainer in ${TRAINERS:-sparse exact dense}; do
    case "$trainer" in
      sparse) how=(--trainer sparse --check-truncation) ;;
      exact) how=(--trainer sparse --gradient-cutoff 0) ;;
      dense) how=(--trainer dense) ;;
      *) echo "unknown trainer $trainer" >&2; exit 2 ;;
    esac
    for seed in 1 2 3; do
      log="$out/$ds-$trainer-s$seed.log"
      if [[ "$ds" == chars ]]; then
        "$b" train --recipe chars --realism clean --seed "$seed" "${how[@]}" \
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
          --seed "$seed" "${how[@]}" --eval-test --out "$tmp/m.safetensors" --force --quiet 2> "$log"
      fi
    done
  done
done
python3 scripts/trainers_table.py > docs/results/trainers.md
