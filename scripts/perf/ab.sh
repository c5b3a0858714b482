#!/usr/bin/env bash
# Times a change against the build before it on a shared, noisy host: two builds of one timing
# command run alternately, ROUNDS times, with every `braille train` job on the machine paused
# (SIGSTOP) for the duration and resumed on exit. How docs/engine.md and docs/reading.md time a
# change ("alternated with the build before"); scripts/perf/ab_summary.py reads the output.
#
#   bash scripts/perf/ab.sh ROUNDS BIN_BEFORE BIN_AFTER [ARGS...]
#
# Each round runs `BIN_BEFORE ARGS` then `BIN_AFTER ARGS` and prints `round name last-line`. The
# builds: copy the timing binary aside before and after the change, e.g.
#   cargo build --release -p experiments --example engine_step && cp target/release/examples/engine_step /tmp/after
#   git stash && cargo build ... && cp ... /tmp/before && git stash pop
#   bash scripts/perf/ab.sh 10 /tmp/before /tmp/after 30 | tee /tmp/ab.txt   # engine_step 30
#   python3 scripts/perf/ab_summary.py /tmp/ab.txt fastest
# Timing commands that print a last line with a labelled figure: `engine_step PASSES` ("fastest
# 0.2025"), `read_probe READS` ("fastest 68.6 ms").
# A ratio within about 3% of 1 may be the heap layout a change leaves rather than the change
# (docs/engine.md, "the 2026-12-04 14:33Z session"); ab_summary.py flags it.
set -euo pipefail
rounds=${1:?rounds} before=${2:?the build before} after=${3:?the build after}
shift 3
[[ $(basename "$before") != $(basename "$after") ]] || { echo "give the two builds different file names" >&2; exit 2; }
paused=$(ps -eo pgid=,args= | awk '/braille train/ && !/awk/ {print $1}' | sort -u)
for p in $paused; do kill -STOP -- "-$p"; done
trap 'for p in $paused; do kill -CONT -- "-$p"; done' EXIT
for i in $(seq "$rounds"); do
  for bin in "$before" "$after"; do
    echo "$i $(basename "$bin") $("$bin" "$@" 2>&1 | tail -1)"
  done
done
