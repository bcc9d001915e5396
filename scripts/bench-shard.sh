#!/usr/bin/env bash
# Benchmark: what splitting a conversion and an index build into N shards
# costs and buys. On one machine shards cannot run faster than the
# unsharded job (it already uses every core), so this measures what
# matters for running them on N machines, each shard with the same
# threads:
#   - each shard's time and input bytes against the unsharded job's (a
#     shard should cost about 1/N of it: it reads only its slices), the
#     slowest shard being the wall time on N machines;
#   - the sum of the shards' times over the unsharded time (the overhead
#     of splitting: apron slices read twice, process start);
#   - the merge (a copy of the parts, every checksum checked);
#   - that the merged files are byte-identical to the unsharded ones.
# Input: the thesis scene as a stack of DIM TIFF slices (the shape of a
# scanner's output), converted to bricked:32 zstd .vvol; then the index
# of that .vvol. Every job runs with THREADS threads (default 1, as a
# shard on a one-core slot would). Medians of RUNS runs; load average
# before and after.
# Usage: scripts/bench-shard.sh [DIM] [N] [RUNS]  (default 800 4 3).
# DIR chooses the directory (default out/bench); KEEP=0 removes the stack.
set -euo pipefail
cd "$(dirname "$0")/.."
DIM=${1:-800}
N=${2:-4}
RUNS=${3:-3}
DIR=${DIR:-out/bench}
KEEP=${KEEP:-1}
THREADS=${THREADS:-1}
export RAYON_NUM_THREADS=$THREADS
mkdir -p "$DIR"
if [ "${BUILD:-1}" = 1 ]; then
    cargo build --release --quiet --bins
fi
B=${CARGO_TARGET_DIR:-target}/release
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
load() { awk '{print $1, $2, $3}' /proc/loadavg; }
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN {printf "%.3f", b - a}'; }

STACK="$DIR/shard-stack-$DIM/"
if [ ! -d "$STACK" ] || [ "$(find "$STACK" -name '*.tif' | wc -l)" != "$DIM" ]; then
    rm -rf "$STACK"
    "$B/vol-gen" shapes --dims "$DIM,$DIM,$DIM" --seed 2 --count 70 --size 70 --value 100 \
        --quiet -o "$DIR/shard-src.vvol"
    "$B/vol-convert" "$DIR/shard-src.vvol" -q -o "$STACK"
    rm -f "$DIR/shard-src.vvol"
fi
CONV=(--layout bricked:32 --compress zstd)
WHOLE="$DIR/shard-whole.vvol"
MERGED="$DIR/shard-merged.vvol"
PART() { echo "$DIR/shard.$1.vpart"; }
IPART() { echo "$DIR/shard.$1.vidxpart"; }

printf '%s^3 u8 thesis scene as %s TIFF slices, %s shards, %s thread(s) per job, %s runs, %s cores\n' \
    "$DIM" "$DIM" "$N" "$THREADS" "$RUNS" "$(nproc)"
LOAD_BEFORE=$(load)
echo "load average before: $LOAD_BEFORE"
: > "$DIR/shard-runs.txt"
for run in $(seq 1 "$RUNS"); do
    # Conversion: unsharded, then the shards one after the other, then merge.
    rm -f "$WHOLE" "$MERGED" "$DIR"/shard.*.vpart "$DIR"/shard.*.vidxpart
    t=$(now)
    j=$("$B/vol-convert" "$STACK" "${CONV[@]}" --json -o "$WHOLE")
    whole_s=$(elapsed "$t")
    whole_in=$(jq .bytes_in <<<"$j")
    shard_s=() shard_in=()
    for k in $(seq 0 $((N - 1))); do
        t=$(now)
        j=$("$B/vol-convert" "$STACK" "${CONV[@]}" --shard "$k/$N" --json -o "$(PART "$k")")
        shard_s+=("$(elapsed "$t")")
        shard_in+=("$(jq .bytes_in <<<"$j")")
    done
    t=$(now)
    # shellcheck disable=SC2046
    "$B/vol-convert" --merge $(for k in $(seq 0 $((N - 1))); do PART "$k"; done) -q -o "$MERGED"
    merge_s=$(elapsed "$t")
    cmp -s "$WHOLE" "$MERGED" && same=identical || same=DIFFERENT
    # Index of the .vvol: unsharded, shards, merge.
    t=$(now)
    "$B/vol-index" "$WHOLE" -q -o "$DIR/shard-whole.vidx"
    iwhole_s=$(elapsed "$t")
    ishard_s=()
    for k in $(seq 0 $((N - 1))); do
        t=$(now)
        "$B/vol-index" "$WHOLE" --shard "$k/$N" -q -o "$(IPART "$k")"
        ishard_s+=("$(elapsed "$t")")
    done
    t=$(now)
    # shellcheck disable=SC2046
    "$B/vol-index" --merge $(for k in $(seq 0 $((N - 1))); do IPART "$k"; done) -q -o "$DIR/shard-merged.vidx"
    imerge_s=$(elapsed "$t")
    cmp -s "$DIR/shard-whole.vidx" "$DIR/shard-merged.vidx" && isame=identical || isame=DIFFERENT
    max() { printf '%s\n' "$@" | sort -g | tail -1; }
    sum() { printf '%s\n' "$@" | awk '{s += $1} END {printf "%.3f", s}'; }
    echo "convert $whole_s $(max "${shard_s[@]}") $(sum "${shard_s[@]}") $merge_s $whole_in $(max "${shard_in[@]}") $same" >> "$DIR/shard-runs.txt"
    echo "index $iwhole_s $(max "${ishard_s[@]}") $(sum "${ishard_s[@]}") $imerge_s 0 0 $isame" >> "$DIR/shard-runs.txt"
    printf 'run %s: convert whole %ss, shards %s s (max %s), merge %ss, %s; index whole %ss, shards %s s, merge %ss, %s\n' \
        "$run" "$whole_s" "${shard_s[*]}" "$(max "${shard_s[@]}")" "$merge_s" "$same" \
        "$iwhole_s" "${ishard_s[*]}" "$imerge_s" "$isame"
done
echo "load average after: $(load)"
echo
printf '| job | unsharded | slowest shard (1/%s ideal) | sum of shards | merge | input read by the biggest shard | result |\n' "$N"
printf '|---|---|---|---|---|---|---|\n'
for job in convert index; do
    col() { awk -v j="$job" -v c="$1" '$1 == j {print $c}' "$DIR/shard-runs.txt" | median; }
    w=$(col 2) m=$(col 3) s=$(col 4) g=$(col 5) win=$(col 6) min=$(col 7)
    res=$(awk -v j="$job" '$1 == j {print $8}' "$DIR/shard-runs.txt" | sort -u | paste -sd/)
    read_share=$(awk -v a="$min" -v b="$win" 'BEGIN {if (b > 0) printf "%.1f%% of the unsharded job'"'"'s", 100 * a / b; else print "-"}')
    awk -v job="$job" -v w="$w" -v m="$m" -v s="$s" -v g="$g" -v rs="$read_share" -v res="$res" 'BEGIN {
        printf "| %s | %.3f s | %.3f s (%.2fx faster) | %.3f s (%.2fx) | %.3f s | %s | %s |\n",
            job, w, m, w / m, s, s / w, g, rs, res }'
done
rm -f "$DIR"/shard.*.vpart "$DIR"/shard.*.vidxpart "$MERGED" "$DIR/shard-merged.vidx"
if [ "$KEEP" = 0 ]; then
    rm -rf "$STACK" "$WHOLE" "$DIR/shard-whole.vidx"
fi
