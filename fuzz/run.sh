#!/usr/bin/env bash
# Runs the fuzz targets for SECONDS each (default 300) with memory limits, from the committed
# seeds: `bash fuzz/run.sh [SECONDS] [TARGET...]` (default: every target). Needs the nightly
# toolchain and cargo-fuzz (`cargo install cargo-fuzz`).
set -euo pipefail
cd "$(dirname "$0")"
seconds=${1:-300}
shift || true
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=(aedat4_decode csv_decode npy_decode model_load nir_import)
for target in "${targets[@]}"; do
  echo "$target:"
  mkdir -p "corpus/$target"
  cargo +nightly fuzz run "$target" "corpus/$target" -- \
    -max_total_time="$seconds" -rss_limit_mb=1024 -malloc_limit_mb=512 -timeout=10 2>&1 |
    grep -E "^#[0-9]+ +DONE|^Done [0-9]+ runs|ERROR|panicked|deadly signal|SUMMARY" || true
done
