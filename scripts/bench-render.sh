#!/usr/bin/env bash
# Benchmark: the thesis's render benchmark, reproduced.
# Scene: vol-gen shapes 800³ (seed 2, 70 shapes, size 70, value 100),
# bricked (B=32) file; 700x700, step 0.2, the 'shapes' transfer function,
# Phong shading, camera at (1100,1100,1100) looking along (-1,-1,-1),
# up (0,1,0), 60° field of view. Each configuration renders --repeat N
# frames in one process and reports the median frame time.
# Targets (issue 5): 2 threads with all optimisations <= 0.3 s; 1 thread
# with them <= 1 s; 1 thread with none <= 12 s; parallel efficiency >= 1.8x.
# Thesis on this machine class: 1.57 s, 9.06 s and 125.6 s.
# Shadows (issue 12): the same scene lit by one directional light, without
# shadows, with shadow rays (target <= 4x) and with light grids at
# divisors 4 and 2 (target <= 1.5x; the grid's build counts in the frame).
# Ambient occlusion (issue 12): the same lit scene with --ao 8 (target <=
# 6x; the occlusion grid's build counts in the frame) and --ao-field 32
# (target <= 1.5x per frame; the field's precomputation is reported apart).
# Usage: scripts/bench-render.sh [DIM] [REPEAT]   (default 800 5)
#        ONLY=shadows scripts/bench-render.sh      (the shadow rows alone)
#        ONLY=ao scripts/bench-render.sh           (the AO rows alone)
set -euo pipefail
cd "$(dirname "$0")/.."
DIM=${1:-800}
REPEAT=${2:-5}
DIR=${DIR:-out/bench}
mkdir -p "$DIR"
cargo build --release --quiet --bins
B=${CARGO_TARGET_DIR:-target}/release
VOL="$DIR/shapes-$DIM-b32.vvol"
SIZE=$((DIM * 70 / 800))
[ -f "$VOL" ] || "$B/vol-gen" shapes --dims "$DIM,$DIM,$DIM" --seed 2 --count 70 --size "$SIZE" --value 100 \
    --layout bricked:32 -o "$VOL" --quiet
E=$((DIM * 1100 / 800))
SCENE=(--tf shapes --shading phong --step 0.2 --size 700x700 --eye "$E,$E,$E" --look-at 0,0,0 --up 0,1,0 --fov 60)
cat "$VOL" > /dev/null   # warm the page cache

field() { sed -n "s/.*\"$1\":\([^,}]*\).*/\1/p"; }
run() { # name, extra args...
    local name=$1; shift
    local j
    j=$("$B/vol-render" "$VOL" "${SCENE[@]}" -o "$DIR/render.png" --json "$@")
    printf '%-38s median %8.3f s  samples %11s  %6.1f M samples/s  peak %7.1f MiB\n' "$name" \
        "$(echo "$j" | field render_s)" "$(echo "$j" | field samples)" \
        "$(echo "$j" | field samples_per_s | awk '{print $1/1e6}')" "$(echo "$j" | field peak_rss_mb)"
    echo "$j" | field render_s > "$DIR/last.txt"
    echo "$j" > "$DIR/last.json"
}

ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.2fx", a/b}'; }
echo "thesis benchmark, ${DIM}^3, load average: $(cut -d' ' -f1-3 /proc/loadavg)"
if [ -z "${ONLY:-}" ]; then
run "2 threads, ERT+ESS, memory-mapped" --threads 2 --repeat "$REPEAT"; t2=$(cat "$DIR/last.txt")
run "2 threads, ERT+ESS, in memory" --threads 2 --repeat "$REPEAT" --in-memory
run "2 threads, ERT+ESS, analytic gradient" --threads 2 --repeat "$REPEAT" --gradient analytic
run "1 thread, ERT+ESS" --threads 1 --repeat "$REPEAT"; t1=$(cat "$DIR/last.txt")
run "1 thread, no ERT, no ESS" --threads 1 --repeat 1 --no-ert --no-ess
echo "parallel efficiency (1 thread / 2 threads): $(ratio "$t1" "$t2")"
fi
LIGHT=(--light 1,2,0.5 --threads 2 --repeat "$REPEAT")
run "2 threads, directional light" "${LIGHT[@]}"; t0=$(cat "$DIR/last.txt")
if [ "${ONLY:-}" != ao ]; then
for sh in "ray" "ray --shadow-step 1" "grid:4" "grid:2"; do
    # shellcheck disable=SC2086 # the method and its options, split
    run "  + shadows $sh" "${LIGHT[@]}" --shadows $sh
    echo "    shadows $sh / no shadows: $(ratio "$(cat "$DIR/last.txt")" "$t0")"
done
fi
if [ "${ONLY:-}" != shadows ]; then
for ao in "--ao 8" "--ao-field 32"; do
    # shellcheck disable=SC2086 # the option and its value, split
    run "  + $ao" "${LIGHT[@]}" $ao
    extra=""
    if [ "$ao" = "--ao-field 32" ]; then
        extra=" (field precomputed once in $(field ao_field_s < "$DIR/last.json" | awk '{printf "%.2f", $1}') s, $(field ao_field_bytes < "$DIR/last.json" | awk '{printf "%.0f", $1/1e6}') MB)"
    fi
    echo "    $ao / no AO: $(ratio "$(cat "$DIR/last.txt")" "$t0")$extra"
done
fi
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
