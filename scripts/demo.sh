#!/usr/bin/env bash
# volkit's main job end to end on built-in data: generate the thesis test
# scene, write it sliced, bricked and zstd-bricked (and in the thesis .vol
# format), and verify every file. Outputs go to $OUT (default out/demo).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-out/demo}
DIMS=${DIMS:-256,256,256}
mkdir -p "$OUT"
cargo build --release --quiet --bins
B=target/release

step() { printf '\n== %s\n' "$*"; }

step "generate the thesis 'shapes' scene ($DIMS), sliced"
$B/vol-gen shapes --dims "$DIMS" --seed 2 --count 70 --size 22 --value 100 -o "$OUT/shapes.vvol"

step "the same scene bricked (B=32) with zstd, and in the thesis .vol format"
$B/vol-gen shapes --dims "$DIMS" --seed 2 --count 70 --size 22 --value 100 \
    --layout bricked:32 --compress zstd -o "$OUT/shapes-zstd.vvol"
$B/vol-gen shapes --dims "$DIMS" --seed 2 --count 70 --size 22 --value 100 \
    --layout bricked:16 -o "$OUT/shapes.vol"

step "through a pipe: generate to stdout, read from stdin"
$B/vol-gen noise --dims 128,128,128 --period 32 -o - | $B/vol-info -

step "verify every file"
for f in "$OUT/shapes.vvol" "$OUT/shapes-zstd.vvol" "$OUT/shapes.vol"; do
    $B/vol-info --verify "$f"
done

printf '\ndemo finished: outputs in %s\n' "$OUT"
