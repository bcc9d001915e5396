#!/usr/bin/env bash
# Load (issue 43, item 4): PROCS vol-render processes at once, each one
# frame of one DIM^3 u8 volume (vol-gen shapes, bricked:32 .vvol: 8 GB at
# 2000^3), on however many cores the machine has (2 in the issue). Every
# process must finish its frame (exit 0, not killed); the script prints,
# per process, the exit status, the wall time, the peak resident memory
# (VmHWM, from /usr/bin/time -v: it counts the mapped file's pages, which
# the page cache shares between the processes) and the peak of its
# anonymous memory (RssAnon, sampled every 0.1 s: what is its own).
# The volume goes to WORK (default a new directory under /var/tmp) and is
# deleted at the end.
# Usage: scripts/bench-load.sh [DIM] [PROCS] [SIZE]   (default 2000 8 512x512)
set -euo pipefail
cd "$(dirname "$0")/.."
DIM=${1:-2000}
PROCS=${2:-8}
SIZE=${3:-512x512}
nice -n 10 cargo build --release -q --bin vol-gen --bin vol-render
BIN=$PWD/target/release
WORK=${WORK:-$(mktemp -d /var/tmp/volkit-load.XXXXXX)}
mkdir -p "$WORK"
trap 'rm -rf "$WORK"' EXIT
VOL=$WORK/big.vvol
t0=$(date +%s)
"$BIN/vol-gen" shapes --dims "$DIM,$DIM,$DIM" --seed 2 --count 70 --size $((DIM / 11)) \
    --layout bricked:32 -q -o "$VOL"
echo "bench-load: $VOL: $(stat -c %s "$VOL") bytes, generated in $(($(date +%s) - t0)) s"
echo "bench-load: $PROCS processes, $(nproc) cores, $(free -g | awk '/Mem:/ {print $2}') GiB RAM, frame $SIZE"

# Peak RssAnon (kB) of the process $1 until it exits, into file $2.
watch_anon() {
    local pid=$1 peak=0 v
    while [ -e "/proc/$pid/status" ]; do
        v=$(awk '/^RssAnon:/ {print $2}' "/proc/$pid/status" 2>/dev/null || true)
        if [ -n "$v" ] && [ "$v" -gt "$peak" ]; then peak=$v; fi
        sleep 0.1
    done
    echo "$peak" >"$2"
}

start=$(date +%s.%N)
pids=()
for i in $(seq 1 "$PROCS"); do
    /usr/bin/time -v "$BIN/vol-render" "$VOL" --tf shapes --size "$SIZE" -q \
        -o "$WORK/frame$i.png" 2>"$WORK/time$i" &
    pids+=($!)
done
# The renderers are the children of /usr/bin/time.
watchers=()
for i in $(seq 1 "$PROCS"); do
    tpid=${pids[$((i - 1))]}
    rpid=""
    for _ in $(seq 1 50); do
        rpid=$(pgrep -P "$tpid" || true)
        [ -n "$rpid" ] && break
        sleep 0.02
    done
    if [ -n "$rpid" ]; then
        watch_anon "$rpid" "$WORK/anon$i" &
        watchers+=($!)
    else
        echo 0 >"$WORK/anon$i"
    fi
done
failed=0
for i in $(seq 1 "$PROCS"); do
    set +e
    wait "${pids[$((i - 1))]}"
    s=$?
    set -e
    [ "$s" = 0 ] || failed=$((failed + 1))
done
wait "${watchers[@]}" 2>/dev/null || true
total=$(echo "$(date +%s.%N) - $start" | bc)
printf '%-4s %-6s %-10s %-14s %-14s %s\n' proc exit wall_s peak_rss_MiB peak_anon_MiB note
for i in $(seq 1 "$PROCS"); do
    f=$WORK/time$i
    st=$(awk -F': ' '/Exit status/ {print $2}' "$f")
    sig=$(grep -o 'Command terminated by signal [0-9]*' "$f" || true)
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$f")
    rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$f")
    anon=$(awk '{printf "%.0f", $1 / 1024}' "$WORK/anon$i")
    printf '%-4s %-6s %-10s %-14s %-14s %s\n' "$i" "${st:-?}" "$wall" "$rss" "$anon" "${sig:-ok}"
done
echo "bench-load: $PROCS frames in $total s, $failed failed or killed"
[ "$failed" = 0 ]
