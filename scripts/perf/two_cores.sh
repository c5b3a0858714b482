#!/usr/bin/env bash
# Whether this host lets two threads scale, beside the engine's two streams: ROUNDS rounds, each
# one round of scripts/perf/two_cores.c (independent vector multiplies and adds in registers, no
# memory) and then one `braille bench --json --streams 2` (the engine, one stream against two).
# Prints both scalings per round, then how many rounds each fell below #52's 1.8x. When the
# register-only loop itself falls below 1.8x, the host is sharing its cores at that moment
# (docs/peers.md, 2026-12-04). `braille bench --streams N` times such a loop in the same rounds
# as the streams (`register_loop`), which pairs them more closely than these rounds do.
#
#   bash scripts/perf/two_cores.sh [ROUNDS]     # default 40; about 2 s a round
set -euo pipefail
cd "$(dirname "$0")/../.."
rounds=${1:-40}
cargo build --release --quiet
probe=$(mktemp)
trap 'rm -f "$probe"' EXIT
gcc -O2 -mavx2 -pthread -o "$probe" scripts/perf/two_cores.c
low_loop=0 low_engine=0
for i in $(seq "$rounds"); do
  loop=$("$probe" 1 | sed 's/.*scaling \([0-9.]*\)x/\1/')
  engine=$(RAYON_NUM_THREADS=1 target/release/braille bench --json --streams 2 |
    python3 -c "import json, sys; print('%.2f' % json.load(sys.stdin)['streams'][1]['speedup'])")
  echo "round $i: register loop ${loop}x, engine ${engine}x"
  low_loop=$((low_loop + $(python3 -c "print(int($loop < 1.8))")))
  low_engine=$((low_engine + $(python3 -c "print(int($engine < 1.8))")))
done
echo "below 1.8x in $rounds rounds: register loop $low_loop, engine's two streams $low_engine"
