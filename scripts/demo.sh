#!/usr/bin/env bash
# volkit's main job end to end on built-in data:
#   generate the thesis test scene -> convert it (TIFF stack and back,
#   zstd bricks) -> build its index -> render it (ray cast, and path
#   traced, continued from a saved state) -> compare renders.
# Every step checks its result; outputs go to $OUT (default out/demo).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-out/demo}
DIMS=${DIMS:-256,256,256}
mkdir -p "$OUT"
cargo build --release --quiet --bins
B=${CARGO_TARGET_DIR:-target}/release

step() { printf '\n== %s\n' "$*"; }

step "generate the thesis 'shapes' scene ($DIMS), sliced"
$B/vol-gen shapes --dims "$DIMS" --seed 2 --count 70 --size 22 --value 100 -o "$OUT/shapes.vvol"

step "convert: to a directory of TIFF slices (as for Fiji) and back, then to zstd bricks"
rm -rf "$OUT/slices"
$B/vol-convert "$OUT/shapes.vvol" -o "$OUT/slices/" --quiet
$B/vol-convert "$OUT/slices" -o "$OUT/from-tiff.vvol" --spacing 1,1,1 --quiet
$B/vol-psnr "$OUT/shapes.vvol" "$OUT/from-tiff.vvol" --min-psnr inf
$B/vol-convert "$OUT/shapes.vvol" -o "$OUT/shapes-zstd.vvol" --layout bricked:32 --compress zstd --quiet
$B/vol-info --verify "$OUT/shapes-zstd.vvol"

step "sharded: the same zstd conversion as 3 independent jobs from the TIFF slices, merged (byte for byte the same file)"
rm -f "$OUT"/shapes.*.vpart
for k in 0 1 2; do
    $B/vol-convert "$OUT/slices" --spacing 1,1,1 --layout bricked:32 --compress zstd --shard "$k/3" -o "$OUT/shapes.$k.vpart" --quiet
done
$B/vol-convert --merge "$OUT"/shapes.*.vpart -o "$OUT/shapes-merged.vvol"
cmp "$OUT/shapes-zstd.vvol" "$OUT/shapes-merged.vvol" && echo "merged shards: identical to the unsharded conversion"
rm -f "$OUT"/shapes.*.vpart

step "through a pipe: generate to stdout, convert from stdin"
$B/vol-gen noise --dims 128,128,128 --period 32 -o - | $B/vol-convert - -o "$OUT/noise.vvol" --layout bricked:32 --quiet
$B/vol-info "$OUT/noise.vvol"

step "index: min/max macrocells and histogram"
$B/vol-index "$OUT/shapes.vvol" --stats -o "$OUT/shapes.vvol.vidx"

step "render: the thesis transfer function with Phong shading"
CAM=(--eye 352,352,352 --look-at 0,0,0 --fov 60 --size 512x512)
$B/vol-render "$OUT/shapes.vvol" --index "$OUT/shapes.vvol.vidx" --tf shapes --shading phong \
    --step 0.2 "${CAM[@]}" -o "$OUT/shapes.png" --hdr "$OUT/shapes.pfm" --heatmap "$OUT/samples.png"
$B/vol-render "$OUT/shapes-zstd.vvol" --tf shapes --shading phong --step 0.2 "${CAM[@]}" \
    -o "$OUT/shapes-zstd.png" --hdr "$OUT/shapes-zstd.pfm" --quiet
$B/vol-render "$OUT/shapes.vvol" --tf shapes --shading phong --step 0.8 "${CAM[@]}" \
    -o "$OUT/coarse.png" --hdr "$OUT/coarse.pfm" --quiet

step "path trace: the scene as a medium under a sun, 8 spp, then 8 more continued from the saved state"
PT=(--mode path --tf shapes --sun=-1,-1.5,-0.5:3 --env 0.2 --bounces 4 --size 256x256 --eye 352,352,352 --look-at 0,0,0 --fov 60)
rm -f "$OUT/pt.state"
$B/vol-render "$OUT/shapes.vvol" --index "$OUT/shapes.vvol.vidx" "${PT[@]}" --spp 8 \
    --accumulate "$OUT/pt.state" -o "$OUT/pt.png" --quiet
$B/vol-render "$OUT/shapes.vvol" --index "$OUT/shapes.vvol.vidx" "${PT[@]}" --spp 8 \
    --accumulate "$OUT/pt.state" -o "$OUT/pt.png" --hdr "$OUT/pt-resumed.pfm"
$B/vol-render "$OUT/shapes.vvol" --index "$OUT/shapes.vvol.vidx" "${PT[@]}" --spp 16 \
    -o "$OUT/pt-once.png" --hdr "$OUT/pt-once.pfm" --quiet
$B/vol-psnr "$OUT/pt-once.pfm" "$OUT/pt-resumed.pfm" --min-psnr inf

step "compare: the zstd copy renders identically; a 4x coarser step costs accuracy"
$B/vol-psnr "$OUT/shapes.pfm" "$OUT/shapes-zstd.pfm" --min-psnr inf
$B/vol-psnr "$OUT/shapes.pfm" "$OUT/coarse.pfm" --diff "$OUT/coarse-error.png"

printf '\ndemo finished: outputs in %s (shapes.png is the render)\n' "$OUT"
