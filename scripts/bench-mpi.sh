#!/usr/bin/env bash
# Benchmark: data-parallel rendering on MPI (issue 17). The thesis's render
# benchmark (800^3 shapes scene, bricked:32 .vvol, 700x700, step 0.2, the
# 'shapes' transfer function, Phong, ERT + ESS) and the same view as MIP,
# rendered in turn, RUNS rounds of:
#   1x1  one process, 1 thread (vol-render --threads 1, no mpirun)
#   Nx1  mpirun -np N, 1 thread per rank (each rank one core's worth)
#   1xN  one process, N threads (the same cores, shared memory)
# Each run renders REPEAT frames and reports the median frame time: for
# one process the render time, for the ranks the wall time from a common
# start to the composited image on rank 0 (render + compositing). Printed:
# medians over the rounds, the ratio 1x1 / Nx1 round by round (target at
# N = 2: >= 1.7x) and Nx1 against 1xN, each rank's render and composite
# seconds, bytes exchanged and peak RSS (a rank touches only its box's
# bricks) against the single process's, and whether the images agree
# (MIP bit for bit, DVR as PSNR). The load average before and after.
# Needs Open MPI (Debian: libopenmpi-dev openmpi-bin libclang-dev
# pkg-config) and jq; builds the tools with --features mpi (BUILD=0 skips).
# Usage: scripts/bench-mpi.sh [N] [RUNS] [REPEAT] [DIM]  (default 2 5 3 800)
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-2}
RUNS=${2:-5}
REPEAT=${3:-3}
DIM=${4:-800}
DIR=${DIR:-out/bench}
mkdir -p "$DIR"
command -v mpirun >/dev/null || { echo "bench-mpi: mpirun not found (install openmpi-bin)" >&2; exit 1; }
command -v jq >/dev/null || { echo "bench-mpi: jq not found" >&2; exit 1; }
if [ "${BUILD:-1}" = 1 ]; then
    cargo build --release --quiet --features mpi --bins
fi
B=${CARGO_TARGET_DIR:-target}/release
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
VOL="$DIR/shapes-$DIM-b32.vvol"
SIZE=$((DIM * 70 / 800))
[ -f "$VOL" ] || "$B/vol-gen" shapes --dims "$DIM,$DIM,$DIM" --seed 2 --count 70 --size "$SIZE" --value 100 \
    --layout bricked:32 -o "$VOL" --quiet
IDX="$DIR/shapes-$DIM-b32.vidx"
[ -f "$IDX" ] || "$B/vol-index" "$VOL" -q -o "$IDX"
E=$((DIM * 1100 / 800))
VIEW=(--size 700x700 --eye "$E,$E,$E" --look-at 0,0,0 --up 0,1,0 --fov 60 --index "$IDX")
cat "$VOL" > /dev/null   # warm the page cache

median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
load() { awk '{print $1, $2, $3}' /proc/loadavg; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.2f", a/b}'; }

printf '%s^3 thesis scene, bricked:32, 700x700, %s ranks, %s rounds of %s frames, %s cores\n' \
    "$DIM" "$N" "$RUNS" "$REPEAT" "$(nproc)"
LOAD_BEFORE=$(load)
echo "load average before: $LOAD_BEFORE"
for mode in dvr mip; do
    case $mode in
        dvr) ARGS=(--mode dvr --tf shapes --shading phong --step 0.2) ;;
        mip) ARGS=(--mode mip --step 0.2) ;;
    esac
    one=() many=() wide=() r=()
    for run in $(seq 1 "$RUNS"); do
        j1=$("$B/vol-render" "$VOL" "${VIEW[@]}" "${ARGS[@]}" --threads 1 --repeat "$REPEAT" \
            -o "$DIR/mpi-one.png" --hdr "$DIR/mpi-one.pfm" --json)
        jn=$(mpirun -q -np "$N" "$B/vol-render" "$VOL" "${VIEW[@]}" "${ARGS[@]}" --threads 1 \
            --repeat "$REPEAT" -o "$DIR/mpi-many.png" --hdr "$DIR/mpi-many.pfm" --json)
        jw=$("$B/vol-render" "$VOL" "${VIEW[@]}" "${ARGS[@]}" --threads "$N" --repeat "$REPEAT" \
            -o "$DIR/mpi-wide.png" --json)
        a=$(jq .render_s <<<"$j1") b=$(jq .render_s <<<"$jn") c=$(jq .render_s <<<"$jw")
        one+=("$a") many+=("$b") wide+=("$c") r+=("$(ratio "$a" "$b")")
        printf '  %s round %s: 1x1 %.3f s  %sx1 %.3f s  1x%s %.3f s  1x1/%sx1 %sx\n' \
            "$mode" "$run" "$a" "$N" "$b" "$N" "$c" "$N" "$(ratio "$a" "$b")"
    done
    m1=$(printf '%s\n' "${one[@]}" | median)
    mn=$(printf '%s\n' "${many[@]}" | median)
    mw=$(printf '%s\n' "${wide[@]}" | median)
    mr=$(printf '%s\n' "${r[@]}" | median)
    echo "$mode: median frame 1x1 $m1 s, ${N}x1 $mn s, 1x$N $mw s"
    echo "$mode: 1x1 / ${N}x1 median of per-round ratios ${mr}x (target at N = 2: >= 1.7x);" \
        "1x$N / ${N}x1 $(ratio "$mw" "$mn")x"
    jq -r '.per_rank[] | "  rank \(.rank): box \(.box), \(.samples) samples, render \(.render_s * 1000 | floor) ms, composite \(.composite_s * 1000 | floor) ms, sent \(.bytes_sent / 1e6) MB, peak RSS \(.peak_rss_mb | floor) MiB"' <<<"$jn"
    echo "  one process (1 thread): $(jq .samples <<<"$j1") samples, peak RSS $(jq '.peak_rss_mb | floor' <<<"$j1") MiB"
    if cmp -s "$DIR/mpi-one.pfm" "$DIR/mpi-many.pfm"; then
        echo "  images: identical"
    else
        echo "  images: $("$B/vol-psnr" "$DIR/mpi-one.pfm" "$DIR/mpi-many.pfm" | head -1)"
    fi
done
echo "load average after: $(load) (before: $LOAD_BEFORE)"
