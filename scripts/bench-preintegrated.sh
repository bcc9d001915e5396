#!/usr/bin/env bash
# Pre-integrated against post-classified DVR at equal error, in one run:
# for each scene, a reference (step 0.01, no early termination), then
# both methods at steps 0.1 to 3.2 (--repeat N, median), PSNR against the
# reference, and the time each method needs for 40 and 45 dB
# (interpolated in log time). Scenes: the harness's thesis scene (sharp
# transfer function, data noisy at the voxel scale) and smooth spheres
# through a thin shell (a transfer function 2 values wide: the case
# pre-integration is for).
#
#   bash scripts/bench-preintegrated.sh            # 256³, 256x256, --repeat 5
#   REPEAT=3 DIM=128 bash scripts/bench-preintegrated.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bins --quiet
bin="${CARGO_TARGET_DIR:-target}/release"
repeat="${REPEAT:-5}"
n="${DIM:-256}"
out="${OUT:-out/bench-preintegrated}"
mkdir -p "$out"
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"

eye=$(( 1100 * n / 800 ))
"$bin/vol-gen" shapes --seed 2 --count 70 --value 100 --size $(( 22 * n / 256 )) \
    --dims "$n,$n,$n" -o "$out/thesis.vvol" --quiet
"$bin/vol-gen" spheres --dims "$n,$n,$n" -o "$out/spheres.vvol" --quiet
cat >"$out/shell.tf" <<'EOF'
domain 0 255
step 1
range 60 61 230 120 60 0.9
range 120 122 250 250 240 0.9
EOF

sweep() {
    local name=$1
    shift
    "$bin/vol-render" "$@" --step 0.01 --no-ert --hdr "$out/$name-ref.pfm" -o "$out/$name-ref.png" -q
    for method in post pre; do
        local flag=""
        [ "$method" = pre ] && flag="--preintegrated"
        for step in 0.1 0.2 0.4 0.8 1.6 3.2; do
            local s
            s=$("$bin/vol-render" "$@" --step "$step" $flag --repeat "$repeat" --json -q \
                --hdr "$out/$name.pfm" -o "$out/$name.png" |
                python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["render_s"], d.get("table_s", 0))')
            local db
            db=$("$bin/vol-psnr" "$out/$name-ref.pfm" "$out/$name.pfm" --json |
                python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["psnr"] if d["psnr"] is not None else 999)')
            echo "$name $method $step $s $db"
        done
    done
}

{
    sweep thesis "$out/thesis.vvol" --tf shapes --shading phong --eye "$eye,$eye,$eye" \
        --look-at 0,0,0 --fov 60 --size 256x256
    sweep spheres "$out/spheres.vvol" --tf "$out/shell.tf" --shading phong --size 256x256
} | tee "$out/rows.txt"
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"

python3 - "$out/rows.txt" <<'EOF'
import math, sys
rows = [l.split() for l in open(sys.argv[1])]
def time_to(pts, db):
    pts = sorted(pts)
    for i, (t, p) in enumerate(pts):
        if p >= db:
            below = [q for q in pts[:i] if q[1] < db]
            if not below:
                return t
            t0, p0 = below[-1]
            f = (db - p0) / (p - p0)
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0)))
    return None
print("| scene | dB | post-classified | pre-integrated | pre / post |")
print("|---|---|---|---|---|")
for scene in sorted({r[0] for r in rows}):
    for db in (40.0, 45.0):
        t = {}
        for m in ("post", "pre"):
            pts = [(float(r[3]), float(r[5])) for r in rows if r[0] == scene and r[1] == m]
            t[m] = time_to(pts, db)
        fmt = lambda x: "–" if x is None else f"{x:.4f} s"
        ratio = "–" if None in t.values() else f"{t['pre'] / t['post']:.2f}"
        print(f"| {scene} | {db:.0f} | {fmt(t['post'])} | {fmt(t['pre'])} | {ratio} |")
EOF
