#!/usr/bin/env bash
# What stick-slip costs the `nominal` headlines (issue #46, item 6): the same test scans (seeds,
# test sensor builds) read with the preset's mount (10 um/N, the middle of the assumed range:
# slips every 0.9 mm at 8 mm/s and 1.5 mm) and with a rigid one (no stick-slip), pair by pair.
# Table I's row at 1.5 mm (RAB, 8 mm/s, 30 scans per row) for ResNet lite NormAug and the SNN;
# the EV word table (8-64 mm/s, 1.5 mm, 30 scans per row, speed estimated) for both readers.
# Writes docs/results/nominal/stick_slip_cost.{md,json}. About 40 minutes on two cores; TRIALS
# (default 30) sets the scans per row on both sides.
# BRAILLE overrides the binary (a snapshot, for long runs while the tree is rebuilt).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -z "${BRAILLE:-}" ]]; then cargo build --release --quiet; fi
b="${BRAILLE:-target/release/braille}"
trials="${TRIALS:-30}"
out=docs/results/nominal
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for mount in preset 0; do
  m=(); if [[ "$mount" != preset ]]; then m=(--mount-compliance-um-per-n "$mount"); fi
  for arch in resnet snn; do
    $b eval chars --arch "$arch" --board RAB --speed 8 --depth 1.5 --trials "$trials" --realism nominal "${m[@]}" --json \
      > "$tmp/chars_${arch}_$mount.json"
    for speed in 8 16 24 32 48 64; do
      $b eval words --arch "$arch" --board EV --speed "$speed" --depth 1.5 --trials "$trials" --realism nominal "${m[@]}" \
        --json > "$tmp/words_${arch}_${speed}_$mount.json"
    done
  done
done
python3 scripts/stick_slip_cost.py "$tmp" "$out" "$trials"
