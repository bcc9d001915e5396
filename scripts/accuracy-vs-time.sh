#!/usr/bin/env bash
# What accuracy costs: build the tools and run vol-accuracy, which sweeps
# vol-render's accuracy knobs and writes out/accuracy/accuracy.csv plus a
# PSNR-against-time plot per scene (PNG and SVG).
#
#   bash scripts/accuracy-vs-time.sh            # default study, a few minutes
#   bash scripts/accuracy-vs-time.sh --quick    # CI-sized, seconds
#   bash scripts/accuracy-vs-time.sh -o DIR --repeat 5 --scene noise
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bins --quiet
target="${CARGO_TARGET_DIR:-target}"
exec "$target/release/vol-accuracy" "$@"
