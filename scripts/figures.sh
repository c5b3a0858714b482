#!/usr/bin/env bash
# Regenerates the figures and tables the README shows (simulated data, labelled as such).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
b=target/release/braille
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# A simulated scan of the EV board, as a heat map and an event raster.
$b simulate --board EV --row 0 --speed 16 --depth 1.0 --seed 0 --realism nominal --out "$tmp/ev.aedat4"
$b plot "$tmp/ev.aedat4" --out docs/results/scan_ev_row0.png --force \
  --title "SIMULATED scan (virtual Evetac, nominal): EV board row 0, RIGHT LEFT EXIT OPEN, 16 mm/s, 1.0 mm"

# The simulator's physics checks at the nominal preset, and one dot's events against its position.
$b sim-check > docs/results/sim_check.md
$b sim-check --json --plot docs/results/sim_check_dot_lag.png > docs/results/sim_check.json
# Stick-slip through the mount: the mechanics over the mount's compliance and the speed.
cargo run --release --quiet -p sim --example stick_slip > docs/results/stick_slip.md
# The labeling pipeline against the simulator's ground truth: the test scans at both presets, and
# the validation boards (where its settings are chosen).
$b label-check --realism clean > docs/results/clean/label_check.md
$b label-check --realism nominal > docs/results/nominal/label_check.md
$b label-check --realism clean --boards validation --trials 10 > docs/results/clean/label_check_val.md
$b label-check --realism nominal --boards validation --trials 10 > docs/results/nominal/label_check_val.md
echo "wrote docs/results/scan_ev_row0.png docs/results/sim_check.{md,json} docs/results/sim_check_dot_lag.png docs/results/stick_slip.md docs/results/{,nominal/}label_check{,_val}.md"
