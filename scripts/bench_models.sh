#!/usr/bin/env bash
# `braille bench --model` on models of ours and graphs made by the peers, on real and simulated
# events, one stream and then two streams on the two cores: docs/results/bench_models.{md,json}.
# Run it on an otherwise idle machine (about 2 minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
out=docs/results/bench_models.jsonl
: > "$out"
# real iCub letters spelling HELLO WORLD (12 taxels), written by the demo
$b demo --out "$tmp" > /dev/null
# the th10 twin exported to NIR, on the th10 test split
$b export --model models/icub/nir/snn-th10.safetensors --out "$tmp/th10.nir" 2> /dev/null
$b bench --model "$tmp/th10.nir" --dt-us 10000 --data data/icub_braille/th10 --split test --streams 2 --json | tr -d '\n' >> "$out"; echo >> "$out"
# the same model file, async mode is not possible (CubaLIF); the Xylo model on its test split
$b bench --model models/icub/chip/xylo-braille7.safetensors --data data/icub_braille/raw1350 --split test --streams 2 --json | tr -d '\n' >> "$out"; echo >> "$out"
# Norse's Braille graph (12 taxels, recurrent CubaLIF, from neuromorphs/NIR) on the real HELLO
# WORLD stream: written for 100 us steps of 5 ms bins, so the stream's times are scaled by 0.02
$b bench --model snn/tests/fixtures/nir/braille/braille_noDelay_bias_zero.nir --dt-us 100 --events "$tmp/icub_text.aedat4" --time-scale 0.02 --streams 2 --json | tr -d '\n' >> "$out"; echo >> "$out"
# snnTorch's conv graph (2x16x16) on random input with the peer statistics
$b bench --model snn/tests/fixtures/nir/conv/conv_snn.nir --samples 64 --streams 2 --json | tr -d '\n' >> "$out"; echo >> "$out"
# the Speck model (IF, convolutions, sum pooling) on random input, stepped and async
for mode in stepped async; do
  $b bench --model models/clean/chip/speck-chars.safetensors --samples 64 --mode "$mode" --streams 2 --json | tr -d '\n' >> "$out"; echo >> "$out"
done
python3 scripts/bench_models.py "$out" > docs/results/bench_models.md
cat docs/results/bench_models.md
