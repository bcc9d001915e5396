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
# The effect rows run in ROUNDS interleaved rounds (default 3): the lit
# frame, then each effect, every ratio against its own round's lit frame;
# the script prints each round's ratio and their median.
# Peers (issue 16), timed in the same run when they are available (the
# script says which it skipped): the thesis renderer through
# ../shared/peers/thesis.sh (built and its volumes generated on first use:
# ~4 min), and VTK's CPU ray caster through scripts/peers/vtk_render.py
# (needs `pip install vtk` and Debian's libosmesa6). Each peer's median over
# REPEAT frames is divided by ours taken just before it, 2 threads (and 1
# thread for VTK). The same voxels as a sliced .vol file (z fastest, the
# thesis's format) are rendered in place as well (target: within 1.3x of
# the bricked file's frame).
# Targets (issue 16): 2 threads <= 0.16 s, >= 5x the thesis renderer and
# >= 7x VTK; 1 thread <= 0.3 s; parallel efficiency >= 1.85x.
# Usage: scripts/bench-render.sh [DIM] [REPEAT]   (default 800 5)
#        ONLY=shadows scripts/bench-render.sh      (the shadow rows alone)
#        ONLY=ao scripts/bench-render.sh           (the AO rows alone)
#        ONLY=peers scripts/bench-render.sh        (ours against the peers)
#        PEERS=0 scripts/bench-render.sh           (no peers)
#        ROUNDS=5 ONLY=shadows scripts/bench-render.sh  (5 rounds of effects)
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
if [ -z "${ONLY:-}" ] || [ "${ONLY:-}" = peers ]; then
run "2 threads, ERT+ESS, memory-mapped" --threads 2 --repeat "$REPEAT"; t2=$(cat "$DIR/last.txt")
if [ -z "${ONLY:-}" ]; then
run "2 threads, ERT+ESS, in memory" --threads 2 --repeat "$REPEAT" --in-memory
run "2 threads, ERT+ESS, analytic gradient" --threads 2 --repeat "$REPEAT" --gradient analytic
fi
run "1 thread, ERT+ESS" --threads 1 --repeat "$REPEAT"; t1=$(cat "$DIR/last.txt")
if [ -z "${ONLY:-}" ]; then run "1 thread, no ERT, no ESS" --threads 1 --repeat 1 --no-ert --no-ess; fi
echo "parallel efficiency (1 thread / 2 threads): $(ratio "$t1" "$t2")"
fi
if [ "${PEERS:-1}" = 0 ] || { [ -n "${ONLY:-}" ] && [ "${ONLY:-}" != peers ]; }; then
    :
elif [ "$DIM" != 800 ]; then
    echo "peers and the sliced .vol row: skipped (the peers' benchmark is 800^3)"
else
    # Our frame again right before each peer, so that each ratio compares
    # frames taken within a minute of each other (this machine drifts).
    again() { "$B/vol-render" "$VOL" "${SCENE[@]}" -o "$DIR/render.png" --json --threads "$1" --repeat "$REPEAT" | field render_s; }
    THESIS=../shared/peers/thesis.sh
    PEER_DIR=${PEER_DIR:-$HOME/.cache/volkit-peers/raycaster_lib}
    # The same voxels as the bricked file, in the thesis's sliced .vol
    # format (z fastest); the thesis renderer reads its own generator's
    # files (the same scene description, other random shapes).
    TVOL="$DIR/shapes-$DIM.vol"
    [ -f "$TVOL" ] || "$B/vol-gen" shapes --dims "$DIM,$DIM,$DIM" --seed 2 --count 70 --size "$SIZE" \
        --value 100 -o "$TVOL" --quiet
    cat "$TVOL" > /dev/null
    j=$("$B/vol-render" "$TVOL" "${SCENE[@]}" -o "$DIR/render-vol.png" --json --threads 2 --repeat "$REPEAT")
    echo "$j" | field render_s > "$DIR/last.txt"
    printf '%-38s median %8.3f s  (opened in %.3f s, index %.3f s)\n' "2 threads, sliced .vol in place" \
        "$(cat "$DIR/last.txt")" "$(echo "$j" | field load_s)" "$(echo "$j" | field index_s)"
    echo "    sliced .vol / bricked .vvol: $(ratio "$(cat "$DIR/last.txt")" "$t2")"
    if [ ! -f "$THESIS" ]; then
        echo "peer thesis renderer: skipped ($THESIS not found)"
    else
        [ -x "$PEER_DIR/target/release/examples/frame" ] || bash "$THESIS" build > "$DIR/thesis-build.log" 2>&1
        [ -f "$PEER_DIR/volumes/800shapes_block16.vol" ] || bash "$THESIS" volumes > "$DIR/thesis-volumes.log" 2>&1
        ours=$(again 2)
        th=$(bash "$THESIS" time "$REPEAT" | sed -n 's/.* median \([0-9.]*\).*/\1/p')
        printf '%-38s median %8.3f s  (vol-render just before: %.3f s)\n' "peer thesis renderer, 2 threads" "$th" "$ours"
        echo "    thesis renderer / vol-render, 2 threads: $(ratio "$th" "$ours")   (target >= 5x)"
    fi
    if ! python3 -c "import vtk" 2> /dev/null; then
        echo "peer VTK: skipped (python3 cannot import vtk: pip install vtk; apt-get install libosmesa6)"
    else
        for n in 2 1; do
            ours=$(again "$n")
            v=$(python3 scripts/peers/vtk_render.py "$TVOL" --threads "$n" --repeat "$REPEAT" | field render_s)
            printf '%-38s median %8.3f s  (vol-render just before: %.3f s)\n' "peer VTK fixed-point ray caster, $n thr" "$v" "$ours"
            echo "    VTK / vol-render, $n thread(s): $(ratio "$v" "$ours")   (target >= 7x at 2 threads)"
        done
    fi
fi
if [ "${ONLY:-}" = peers ]; then
    echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
    exit 0
fi
LIGHT=(--light 1,2,0.5 --threads 2 --repeat "$REPEAT")
# The effect rows, interleaved: each round renders the lit frame and then
# every effect, and each effect's ratio is taken against the lit frame of
# its own round (this machine drifts by more than the effects' margins);
# the script prints every round's ratio and their median.
ROUNDS=${ROUNDS:-3}
EFFECTS=()
if [ "${ONLY:-}" != ao ]; then
    EFFECTS+=("--shadows ray" "--shadows ray --shadow-step 1" "--shadows grid:4" "--shadows grid:2")
fi
if [ "${ONLY:-}" != shadows ]; then EFFECTS+=("--ao 8" "--ao-field 32"); fi
declare -A RATIOS=()
echo "effects: $ROUNDS interleaved rounds, each against its round's lit frame"
for round in $(seq 1 "$ROUNDS"); do
    echo "round $round, load average $(cut -d' ' -f1 /proc/loadavg)"
    run "  2 threads, directional light" "${LIGHT[@]}"; t0=$(cat "$DIR/last.txt")
    for e in "${EFFECTS[@]}"; do
        # shellcheck disable=SC2086 # the option and its values, split
        run "  + ${e#--}" "${LIGHT[@]}" $e
        r=$(ratio "$(cat "$DIR/last.txt")" "$t0")
        extra=""
        if [ "$e" = "--shadows grid:4" ] || [ "$e" = "--shadows grid:2" ]; then
            extra=" (grid built in $(field shadow_grid_s < "$DIR/last.json" | awk '{printf "%.3f", $1}') s, $(field shadow_grid_bytes < "$DIR/last.json" | awk '{printf "%.0f", $1/1e6}') MB)"
        elif [ "$e" = "--ao-field 32" ]; then
            extra=" (field precomputed once in $(field ao_field_s < "$DIR/last.json" | awk '{printf "%.2f", $1}') s, $(field ao_field_bytes < "$DIR/last.json" | awk '{printf "%.0f", $1/1e6}') MB)"
        fi
        echo "    ${e#--} / lit frame: $r$extra"
        RATIOS[$e]="${RATIOS[$e]:-} ${r%x}"
    done
done
echo "effects, median of the per-round ratios to the lit frame (targets: shadows grid:4 <= 1.5x, ray <= 4x; ao 8 <= 6x, ao-field 32 <= 1.5x):"
for e in "${EFFECTS[@]}"; do
    # shellcheck disable=SC2086 # one ratio per round
    printf '  %-32s %sx  (rounds:%s)\n' "${e#--}" "$(printf '%s\n' ${RATIOS[$e]} | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}')" "${RATIOS[$e]}"
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
