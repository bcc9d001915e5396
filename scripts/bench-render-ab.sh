#!/usr/bin/env bash
# Two vol-render binaries on the thesis benchmark, interleaved: A, B, A, B,
# ... in the same run, so a change's effect on frame time is a ratio
# measured on the same machine in the same minutes (machines here drift by
# more than the effects worth measuring). Each run renders --repeat N
# frames in one process and reports their median; the script prints, per
# configuration, the median of A's and of B's runs and the median and
# range of the per-round ratios B/A.
# The volume must be readable by both binaries (an older binary may not
# read a newer file format: make it with the older vol-gen).
# Usage: scripts/bench-render-ab.sh OLD_VOL_RENDER NEW_VOL_RENDER VOLUME [REPEAT] [ROUNDS] [DIM]
#   REPEAT frames per run (default 7), ROUNDS A/B pairs (default 3),
#   DIM the volume's edge, for the camera (default 800).
set -euo pipefail
A=$1
B=$2
VOL=$3
REPEAT=${4:-7}
ROUNDS=${5:-3}
DIM=${6:-800}
E=$((DIM * 1100 / 800))
SCENE=(--tf shapes --shading phong --step 0.2 --size 700x700 --eye "$E,$E,$E" --look-at 0,0,0 --up 0,1,0 --fov 60)
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
cat "$VOL" > /dev/null

render_s() { # binary, args...
    local bin=$1
    shift
    "$bin" "$VOL" "${SCENE[@]}" -o "$OUT/r.png" --json "$@" | sed -n 's/.*"render_s":\([^,}]*\).*/\1/p'
}

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

echo "A: $A"
echo "B: $B"
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-36s %10s %10s %10s %17s\n' configuration "A median" "B median" "B/A" "B/A range"
bench() { # name, repeat, args...
    local name=$1 rep=$2
    shift 2
    local as=() bs=() rs=()
    for _ in $(seq "$ROUNDS"); do
        local a b
        a=$(render_s "$A" --repeat "$rep" "$@")
        b=$(render_s "$B" --repeat "$rep" "$@")
        as+=("$a")
        bs+=("$b")
        rs+=("$(awk -v a="$a" -v b="$b" 'BEGIN {printf "%.4f", b / a}')")
    done
    printf '%-36s %9.4fs %9.4fs %10.3f %8.3f-%.3f\n' "$name" \
        "$(printf '%s\n' "${as[@]}" | median)" "$(printf '%s\n' "${bs[@]}" | median)" \
        "$(printf '%s\n' "${rs[@]}" | median)" \
        "$(printf '%s\n' "${rs[@]}" | sort -g | head -1)" "$(printf '%s\n' "${rs[@]}" | sort -g | tail -1)"
}
bench "2 threads, ERT+ESS, memory-mapped" "$REPEAT" --threads 2
bench "2 threads, ERT+ESS, in memory" "$REPEAT" --threads 2 --in-memory
bench "2 threads, ERT+ESS, analytic gradient" "$REPEAT" --threads 2 --gradient analytic
bench "1 thread, ERT+ESS" "$REPEAT" --threads 1
bench "1 thread, no ERT, no ESS" 1 --threads 1 --no-ert --no-ess
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
