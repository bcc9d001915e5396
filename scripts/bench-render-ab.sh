#!/usr/bin/env bash
# Two vol-render binaries on the thesis benchmark, interleaved: A, B, A, B,
# ... in the same run, so a change's effect on frame time is a ratio
# measured on the same machine in the same minutes (machines here drift by
# more than the effects worth measuring). Each run renders --repeat N
# frames in one process and reports their median; the script prints, per
# configuration, the median of A's and of B's runs and the median and
# range of the per-round ratios B/A (below 1: B is faster).
# Configurations: every row of bench-render.sh (2 threads and 1, with and
# without ERT/ESS, analytic gradient, in memory), the effect rows (one
# directional light: shadows grid:4 and ray, --ao 8, --ao-field 32), and
# when given the sliced .vol (TVOL) and the path tracer's dense scene of
# bench-path.sh (PATHVOL: 64 spp, 8 bounces).
# The volumes must be readable by both binaries (an older binary may not
# read a newer file format: make them with the older vol-gen).
# Usage: scripts/bench-render-ab.sh OLD_VOL_RENDER NEW_VOL_RENDER VOLUME [REPEAT] [ROUNDS] [DIM]
#   REPEAT frames per run (default 7), ROUNDS A/B pairs (default 7),
#   DIM the volume's edge, for the camera (default 800).
#   TVOL=out/bench/shapes-800.vol     the same voxels as a sliced .vol
#   PATHVOL=out/bench-path/dense.vvol the path tracer's dense scene
#   ONLY="frames|effects|vol|path"    some groups of rows only
set -euo pipefail
A=$1
B=$2
VOL=$3
REPEAT=${4:-7}
ROUNDS=${5:-7}
DIM=${6:-800}
E=$((DIM * 1100 / 800))
SCENE=(--tf shapes --shading phong --step 0.2 --size 700x700 --eye "$E,$E,$E" --look-at 0,0,0 --up 0,1,0 --fov 60)
LIGHT=(--light 1,2,0.5 --threads 2)
PATH_SCENE=(--mode path --density-scale 0.1 --albedo 0.8 "--sun=-1,-1.2,0.4:4" --env 0.1 --spp 64 --bounces 8
    --size 256x256 "--eye=249.53,198.92,385.72" --look-at 63.5,63.5,63.5 --up 0,1,0 --fov 45 --threads 2)
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
cat "$VOL" > /dev/null
[ -z "${TVOL:-}" ] || cat "$TVOL" > /dev/null
[ -z "${PATHVOL:-}" ] || cat "$PATHVOL" > /dev/null

field() { sed -n "s/.*\"$1\": *\([^,}]*\).*/\1/p"; }
render_s() { # binary, volume, args...
    local bin=$1 vol=$2
    shift 2
    "$bin" "$vol" -o "$OUT/r.png" --json --quiet "$@" | field render_s
}

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
want() { [ -z "${ONLY:-}" ] || [[ " $ONLY " == *" $1 "* ]]; }

echo "A: $A"
echo "B: $B"
echo "rounds: $ROUNDS, frames per run: $REPEAT; load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-40s %10s %10s %10s %17s\n' configuration "A median" "B median" "B/A" "B/A range"
bench() { # name, volume, args...
    local name=$1 vol=$2
    shift 2
    local as=() bs=() rs=()
    for _ in $(seq "$ROUNDS"); do
        local a b
        a=$(render_s "$A" "$vol" "$@")
        b=$(render_s "$B" "$vol" "$@")
        as+=("$a")
        bs+=("$b")
        rs+=("$(awk -v a="$a" -v b="$b" 'BEGIN {printf "%.4f", b / a}')")
    done
    printf '%-40s %9.4fs %9.4fs %10.3f %8.3f-%.3f\n' "$name" \
        "$(printf '%s\n' "${as[@]}" | median)" "$(printf '%s\n' "${bs[@]}" | median)" \
        "$(printf '%s\n' "${rs[@]}" | median)" \
        "$(printf '%s\n' "${rs[@]}" | sort -g | head -1)" "$(printf '%s\n' "${rs[@]}" | sort -g | tail -1)"
}
if want frames; then
    bench "2 threads, ERT+ESS, memory-mapped" "$VOL" "${SCENE[@]}" --repeat "$REPEAT" --threads 2
    bench "2 threads, ERT+ESS, in memory" "$VOL" "${SCENE[@]}" --repeat "$REPEAT" --threads 2 --in-memory
    bench "2 threads, ERT+ESS, analytic gradient" "$VOL" "${SCENE[@]}" --repeat "$REPEAT" --threads 2 --gradient analytic
    bench "1 thread, ERT+ESS" "$VOL" "${SCENE[@]}" --repeat "$REPEAT" --threads 1
    bench "1 thread, no ERT, no ESS" "$VOL" "${SCENE[@]}" --repeat 1 --threads 1 --no-ert --no-ess
fi
if want vol && [ -n "${TVOL:-}" ]; then
    bench "2 threads, sliced .vol in place" "$TVOL" "${SCENE[@]}" --repeat "$REPEAT" --threads 2
fi
if want effects; then
    bench "2 threads, directional light" "$VOL" "${SCENE[@]}" "${LIGHT[@]}" --repeat "$REPEAT"
    bench "  + shadows grid:4" "$VOL" "${SCENE[@]}" "${LIGHT[@]}" --repeat "$REPEAT" --shadows grid:4
    bench "  + shadows ray" "$VOL" "${SCENE[@]}" "${LIGHT[@]}" --repeat 3 --shadows ray
    bench "  + ao 8" "$VOL" "${SCENE[@]}" "${LIGHT[@]}" --repeat 3 --ao 8
    bench "  + ao-field 32" "$VOL" "${SCENE[@]}" "${LIGHT[@]}" --repeat "$REPEAT" --ao-field 32
fi
if want path && [ -n "${PATHVOL:-}" ]; then
    bench "path tracing, dense, 64 spp, 8 bounces" "$PATHVOL" "${PATH_SCENE[@]}"
fi
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
