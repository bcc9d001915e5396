#!/usr/bin/env bash
# Issue 54's full-size row: the thesis scene at 800³ and 700x700 with the
# step sweep, --budget and --adaptive, each against a step-0.01 reference
# (PSNR of the float images, peak 1.0; medians of --repeat 5). Prints a
# CSV (knob, value, frame seconds, probe seconds, step factor, scale,
# PSNR). Needs about 1 GB of disk and 2 minutes on 2 cores.
#
#   bash scripts/budget-800.sh [OUT_DIR]      # default out/budget-800
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bins --quiet
bin="${CARGO_TARGET_DIR:-target}/release"
out="${1:-out/budget-800}"
mkdir -p "$out"
vol="$out/t800.vvol"
[ -f "$vol" ] || "$bin/vol-gen" shapes --seed 2 --count 70 --value 100 --size 70 \
    --dims 800,800,800 -o "$vol" --quiet
view=("$vol" --tf shapes --shading phong --eye 1100,1100,1100 --look-at 0,0,0
    --fov 60 --size 700x700)
[ -f "$out/ref.pfm" ] || "$bin/vol-render" "${view[@]}" --step 0.01 --no-ert \
    --hdr "$out/ref.pfm" -o "$out/ref.png" --quiet
psnr() { "$bin/vol-psnr" "$out/ref.pfm" "$1" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["psnr"])'; }
echo "# $(uptime)" >&2
echo "knob,value,frame_s,probe_s,step_factor,scale,psnr_db"
for s in 0.05 0.1 0.2 0.4 0.8 1.6; do
    t=$("$bin/vol-render" "${view[@]}" --step "$s" --repeat 5 --hdr "$out/x.pfm" -o "$out/x.png" --json |
        python3 -c 'import json,sys; print(json.load(sys.stdin)["render_s"])')
    echo "step,$s,$t,0,1,1,$(psnr "$out/x.pfm")"
done
for b in 0.1 0.2 0.4 0.8 1.6; do
    t=$("$bin/vol-render" "${view[@]}" --step 0.2 --budget "$b" --repeat 5 --hdr "$out/x.pfm" -o "$out/x.png" --json |
        python3 -c 'import json,sys; d=json.load(sys.stdin); b=d["budget"]; print(d["render_s"], b["probe_s"], b["step_factor"], b["scale"], sep=",")')
    echo "budget,$b,$t,$(psnr "$out/x.pfm")"
done
for a in 0.001 0.003 0.01; do
    t=$("$bin/vol-render" "${view[@]}" --step 0.05 --adaptive "$a" --repeat 5 --hdr "$out/x.pfm" -o "$out/x.png" --json |
        python3 -c 'import json,sys; print(json.load(sys.stdin)["render_s"])')
    echo "adaptive,$a,$t,0,1,1,$(psnr "$out/x.pfm")"
done
echo "# $(uptime)" >&2
