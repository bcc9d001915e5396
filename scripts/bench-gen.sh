#!/usr/bin/env bash
# Benchmark: how fast vol-gen writes the thesis benchmark volume compared
# with the disk itself. Each run times, back to back in the same directory:
#   head -c N /dev/zero > file              (the disk's write speed)
#   vol-gen shapes ... sliced u8 .vvol      (target: at most 1.5x head)
#   vol-gen shapes ... bricked:32 zstd      (target: at most 3x head)
# and prints the per-run times, then medians and the medians of the
# per-run ratios. Usage: scripts/bench-gen.sh [DIM] [RUNS]  (default 800 5).
# Set DIR to choose the output directory (default out/bench, on disk).
set -euo pipefail
cd "$(dirname "$0")/.."
DIM=${1:-800}
RUNS=${2:-5}
DIR=${DIR:-out/bench}
mkdir -p "$DIR"
cargo build --release --quiet --bins
B=${CARGO_TARGET_DIR:-target}/release
N=$((DIM * DIM * DIM))
SCENE=(shapes --dims "$DIM,$DIM,$DIM" --seed 2 --count 70 --size 70 --value 100 --quiet)

now() { date +%s.%N; }
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }

: > "$DIR/runs.txt"
printf 'run  head_s  sliced_s  zstd_s  sliced/head  zstd/head\n'
for r in $(seq 1 "$RUNS"); do
    rm -f "$DIR/zero.bin" "$DIR/sliced.vvol" "$DIR/zstd.vvol"
    # Flush between commands so nobody pays for another's writeback.
    sync; t0=$(now); head -c "$N" /dev/zero > "$DIR/zero.bin"; t1=$(now)
    sync; t2=$(now); "$B/vol-gen" "${SCENE[@]}" -o "$DIR/sliced.vvol"; t3=$(now)
    sync; t4=$(now); "$B/vol-gen" "${SCENE[@]}" --layout bricked:32 --compress zstd -o "$DIR/zstd.vvol"; t5=$(now)
    awk -v r="$r" -v a="$t0" -v b="$t1" -v c="$t2" -v d="$t3" -v e="$t4" -v f="$t5" 'BEGIN {
        h=b-a; s=d-c; z=f-e;
        printf "%3d  %6.3f  %8.3f  %6.3f  %11.2f  %9.2f\n", r, h, s, z, s/h, z/h }' | tee -a "$DIR/runs.txt"
done
hm=$(awk '{print $2}' "$DIR/runs.txt" | median)
sm=$(awk '{print $3}' "$DIR/runs.txt" | median)
zm=$(awk '{print $4}' "$DIR/runs.txt" | median)
sr=$(awk '{print $5}' "$DIR/runs.txt" | median)
zr=$(awk '{print $6}' "$DIR/runs.txt" | median)
zbytes=$(stat -c %s "$DIR/zstd.vvol")
printf '\n%s^3 u8 (%s bytes), %s runs, medians:\n' "$DIM" "$N" "$RUNS"
printf '  head -c     %6.3f s\n' "$hm"
printf '  vol-gen     %6.3f s sliced  (ratio %.2fx, target <= 1.5x)\n' "$sm" "$sr"
printf '  vol-gen     %6.3f s zstd    (ratio %.2fx, target <= 3x; %s bytes)\n' "$zm" "$zr" "$zbytes"
printf '  thesis generator on this machine class: about 27 s for 800^3 (%.0fx slower than sliced vol-gen here)\n' \
    "$(awk -v s="$sm" 'BEGIN {print 27/s}')"
printf '{"bench":"gen","dim":%s,"runs":%s,"head_s":%s,"sliced_s":%s,"zstd_s":%s,"sliced_ratio":%s,"zstd_ratio":%s,"zstd_bytes":%s}\n' \
    "$DIM" "$RUNS" "$hm" "$sm" "$zm" "$sr" "$zr" "$zbytes" > "$DIR/gen.json"
rm -f "$DIR/zero.bin" "$DIR/sliced.vvol" "$DIR/zstd.vvol"
