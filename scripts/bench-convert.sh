#!/usr/bin/env bash
# Benchmark: vol-convert on a stack of single-page TIFFs (issue 3's speed
# targets). A DIM^3 u8 scene of a few dozen soft ellipsoids is written once
# as DIM single-page TIFFs; then each run times, back to back, warm cache:
#   cp -r slices/ copy/                       (the same bytes, copied)
#   vol-convert slices/ -o sliced.vvol        (target: <= tifffile's time)
#   vol-convert slices/ --layout bricked:B --compress zstd:3 -o z.vvol
#     for B = 64 and 128                      (target: <= half zarr's time,
#                                              compression within 10%)
# with peak resident memory and CPU time (user + system, all threads) of
# each vol-convert (from /usr/bin/time, else VmHWM and no CPU figure).
# CPU time is reported because the machine may be shared: wall times then
# include waiting for other jobs. Bricks store a 1+2 voxel apron, so B = 64
# stores 67^3 voxels per 64^3 (+15% before compression); B = 128 stores
# +7%, which is what brings the ratio near zarr's apron-less 64^3 chunks. If PY names a Python with numpy, tifffile and zarr 3, the same
# runs time tifffile (read the slices, write one raw file) and zarr (read
# the slices with tifffile, write 64^3 chunks, zstd level 3, one shard
# file) for the baselines; otherwise the issue's figures are used (0.33 s and 0.9 s for
# 512^3, scaled by DIM^3).
#
# Then (PY with SimpleITK) .nii -> .nii.gz against SimpleITK: see the end.
#
# Usage: scripts/bench-convert.sh [DIM] [RUNS]   (default 512 5)
#        BIG=2000 scripts/bench-convert.sh       also converts a BIG^3 u8
#                                                stack once for peak memory
# Set DIR for the working directory (default out/bench-convert, on disk).
set -euo pipefail
cd "$(dirname "$0")/.."
DIM=${1:-512}
RUNS=${2:-5}
DIR=${DIR:-out/bench-convert}
PY=${PY:-}
mkdir -p "$DIR"
cargo build --release --quiet --bin vol-gen --bin vol-convert
B=${CARGO_TARGET_DIR:-target}/release
N=$((DIM * DIM * DIM))

now() { date +%s.%N; }
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }

# Run a command, print "seconds peak_kib cpu_seconds" (peak resident set
# and user + system time of the command; cpu 0 when unknown).
timed() {
    local t0 t1 kib cpu=0
    if [ -x /usr/bin/time ]; then
        t0=$(now)
        /usr/bin/time -f '%M %U %S' -o "$DIR/time.txt" "$@"
        t1=$(now)
        read -r kib u s < <(tail -n 1 "$DIR/time.txt")
        cpu=$(awk -v u="$u" -v s="$s" 'BEGIN {print u + s}')
    else
        t0=$(now)
        "$@" &
        local pid=$! hwm=0 v
        while kill -0 "$pid" 2>/dev/null; do
            v=$(awk '/VmHWM/ {print $2}' "/proc/$pid/status" 2>/dev/null || echo 0)
            [ "${v:-0}" -gt "$hwm" ] && hwm=$v
            sleep 0.02
        done
        wait "$pid"
        t1=$(now)
        kib=$hwm
    fi
    awk -v a="$t0" -v b="$t1" -v k="$kib" -v c="$cpu" 'BEGIN {printf "%.4f %d %.2f\n", b-a, k, c}'
}

SCENE=(spheres --dims "$DIM,$DIM,$DIM" --seed 3 --count 36 --size $((DIM / 8)) --quiet)
if [ ! -d "$DIR/slices" ] || [ "$(ls "$DIR/slices" | wc -l)" -ne "$DIM" ]; then
    rm -rf "$DIR/slices"
    "$B/vol-gen" "${SCENE[@]}" -o "$DIR/scene_${DIM}x${DIM}x${DIM}_uint8.raw"
    "$B/vol-convert" "$DIR/scene_${DIM}x${DIM}x${DIM}_uint8.raw" -q -o "$DIR/slices/"
    rm -f "$DIR/scene_${DIM}x${DIM}x${DIM}_uint8.raw"
fi
SLICE_BYTES=$(du -cb "$DIR"/slices/*.tif | tail -n 1 | cut -f 1)

have_py=0
if [ -n "$PY" ] && "$PY" -c 'import numpy, tifffile, zarr' 2>/dev/null; then
    have_py=1
    cat > "$DIR/baseline.py" <<'EOF'
import glob, os, shutil, sys, time
import numpy as np, tifffile, zarr
d, dim = sys.argv[1], int(sys.argv[2])
files = sorted(glob.glob(os.path.join(d, "slices", "*.tif")))
t0 = time.perf_counter()
with open(os.path.join(d, "tifffile.raw"), "wb") as f:
    for p in files:
        f.write(tifffile.imread(p).tobytes())
t1 = time.perf_counter()
store = os.path.join(d, "zarr")
shutil.rmtree(store, ignore_errors=True)
t2 = time.perf_counter()
vol = np.empty((dim, dim, dim), dtype=np.uint8)
for i, p in enumerate(files):
    vol[i] = tifffile.imread(p)
z = zarr.create_array(store=store, shape=vol.shape, chunks=(64, 64, 64), shards=vol.shape,
                      dtype="uint8", compressors=zarr.codecs.ZstdCodec(level=3))
z[:] = vol
t3 = time.perf_counter()
size = sum(os.path.getsize(os.path.join(r, n)) for r, _, ns in os.walk(store) for n in ns)
print(f"{t1 - t0:.4f} {t3 - t2:.4f} {size}")
EOF
fi

: > "$DIR/runs.txt"
printf 'run   cp_s  sliced_s  z64_s  z128_s  tifffile_s  zarr_s | cpu_s: sliced z64 z128 | peak MiB: sliced z64 z128\n'
for r in $(seq 1 "$RUNS"); do
    rm -rf "$DIR/copy" "$DIR/sliced.vvol" "$DIR/z64.vvol" "$DIR/z128.vvol"
    sync
    t0=$(now); cp -r "$DIR/slices" "$DIR/copy"; t1=$(now)
    cp_s=$(awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%.4f", b-a}')
    sync
    read -r s_s s_k s_c < <(timed "$B/vol-convert" "$DIR/slices" -q -o "$DIR/sliced.vvol")
    sync
    read -r z_s z_k z_c < <(timed "$B/vol-convert" "$DIR/slices" --layout bricked:64 --compress zstd:3 -q -o "$DIR/z64.vvol")
    sync
    read -r y_s y_k y_c < <(timed "$B/vol-convert" "$DIR/slices" --layout bricked:128 --compress zstd:3 -q -o "$DIR/z128.vvol")
    if [ "$have_py" = 1 ]; then
        sync
        read -r tf_s zr_s zr_bytes < <("$PY" "$DIR/baseline.py" "$DIR" "$DIM")
    else
        tf_s=$(awk -v n="$N" 'BEGIN {printf "%.4f", 0.33 * n / 134217728}')
        zr_s=$(awk -v n="$N" 'BEGIN {printf "%.4f", 0.9 * n / 134217728}')
        zr_bytes=0
    fi
    echo "$r $cp_s $s_s $z_s $y_s $tf_s $zr_s $s_c $z_c $y_c $s_k $z_k $y_k $zr_bytes" >> "$DIR/runs.txt"
    awk -v r="$r" -v c="$cp_s" -v s="$s_s" -v z="$z_s" -v y="$y_s" -v tf="$tf_s" -v zr="$zr_s" \
        -v sc="$s_c" -v zc="$z_c" -v yc="$y_c" -v sk="$s_k" -v zk="$z_k" -v yk="$y_k" 'BEGIN {
        printf "%3d  %5.3f  %8.3f  %5.3f  %6.3f  %10.3f  %6.3f | %5.2f %5.2f %5.2f | %5.1f %5.1f %5.1f\n",
            r, c, s, z, y, tf, zr, sc, zc, yc, sk/1024, zk/1024, yk/1024 }'
done
col() { awk -v c="$1" '{print $c}' "$DIR/runs.txt" | median; }
cp_m=$(col 2); s_m=$(col 3); z_m=$(col 4); y_m=$(col 5); tf_m=$(col 6); zr_m=$(col 7)
s_c=$(col 8); z_c=$(col 9); y_c=$(col 10)
s_k=$(col 11); z_k=$(col 12); y_k=$(col 13); zr_bytes=$(col 14)
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {printf "%.2f", a/b}'; }
mib() { awk -v k="$1" 'BEGIN {printf "%.1f", k/1024}'; }
z64_ratio=$(ratio "$N" "$(stat -c %s "$DIR/z64.vvol")")
z128_ratio=$(ratio "$N" "$(stat -c %s "$DIR/z128.vvol")")
if [ "$have_py" = 1 ]; then
    zr_ratio=$(ratio "$N" "$zr_bytes")
    zr_note="zarr ${zr_ratio}x"
else
    zr_ratio=0
    zr_note="zarr not measured: set PY"
fi
printf '\n%s^3 u8 as %s single-page TIFFs (%s bytes of files), %s runs, medians (wall s, cpu s):\n' "$DIM" "$DIM" "$SLICE_BYTES" "$RUNS"
printf '  cp -r             %6.3f s  (%.0f MB/s)\n' "$cp_m" "$(awk -v b="$SLICE_BYTES" -v t="$cp_m" 'BEGIN {print b/t/1e6}')"
printf '  tifffile -> raw   %6.3f s  %s\n' "$tf_m" "$([ "$have_py" = 1 ] && echo measured || echo "the issue's figure, scaled")"
printf '  zarr 64^3 zstd:3  %6.3f s  %s\n' "$zr_m" "$([ "$have_py" = 1 ] && echo "measured, ratio ${zr_ratio}x" || echo "the issue's figure, scaled")"
printf '  sliced .vvol      %6.3f s  cpu %s s  %sx cp  %sx tifffile (target <= 1)  peak %s MiB\n' \
    "$s_m" "$s_c" "$(ratio "$s_m" "$cp_m")" "$(ratio "$s_m" "$tf_m")" "$(mib "$s_k")"
printf '  bricked:64 zstd   %6.3f s  cpu %s s  %sx cp  %sx zarr (target <= 0.5)  ratio %sx vs %s  peak %s MiB\n' \
    "$z_m" "$z_c" "$(ratio "$z_m" "$cp_m")" "$(ratio "$z_m" "$zr_m")" "$z64_ratio" "$zr_note" "$(mib "$z_k")"
printf '  bricked:128 zstd  %6.3f s  cpu %s s  %sx cp  %sx zarr (target <= 0.5)  ratio %sx vs %s  peak %s MiB\n' \
    "$y_m" "$y_c" "$(ratio "$y_m" "$cp_m")" "$(ratio "$y_m" "$zr_m")" "$z128_ratio" "$zr_note" "$(mib "$y_k")"
printf '{"bench":"convert","dim":%s,"runs":%s,"cp_s":%s,"sliced_s":%s,"z64_s":%s,"z128_s":%s,"tifffile_s":%s,"zarr_s":%s,"sliced_cpu_s":%s,"z64_cpu_s":%s,"z128_cpu_s":%s,"z64_ratio":%s,"z128_ratio":%s,"zarr_ratio":%s,"sliced_peak_kib":%s,"z64_peak_kib":%s,"z128_peak_kib":%s,"baselines_measured":%s}\n' \
    "$DIM" "$RUNS" "$cp_m" "$s_m" "$z_m" "$y_m" "$tf_m" "$zr_m" "$s_c" "$z_c" "$y_c" "$z64_ratio" "$z128_ratio" "$zr_ratio" "$s_k" "$z_k" "$y_k" "$have_py" > "$DIR/convert.json"
rm -rf "$DIR/copy" "$DIR/sliced.vvol" "$DIR/z64.vvol" "$DIR/z128.vvol" "$DIR/tifffile.raw" "$DIR/zarr"

if [ -n "${BIG:-}" ]; then
    # Peak memory on a large stack: BIG^3 u8 as BIG single-page TIFFs.
    BD="$DIR/big"
    if [ ! -d "$BD/slices" ] || [ "$(ls "$BD/slices" | wc -l)" -ne "$BIG" ]; then
        rm -rf "$BD"; mkdir -p "$BD"
        "$B/vol-gen" spheres --dims "$BIG,$BIG,$BIG" --seed 3 --count 36 --size $((BIG / 8)) --quiet -o - |
            "$B/vol-convert" - -q -o "$BD/slices/"
    fi
    for layout in sliced bricked:64; do
        extra=()
        [ "$layout" != sliced ] && extra=(--compress zstd:3)
        sync
        read -r t k c < <(timed "$B/vol-convert" "$BD/slices" --layout "$layout" "${extra[@]}" -q -o "$BD/out.vvol")
        printf '  %s^3 %-10s %7.1f s  cpu %s s  peak %.0f MiB  (%s bytes out)\n' "$BIG" "$layout" "$t" "$c" "$(awk -v k="$k" 'BEGIN {print k/1024}')" "$(stat -c %s "$BD/out.vvol")"
        rm -f "$BD/out.vvol"
    done
fi

# gzip: a CT-like DIM x DIM x DIM/2 i16 volume (vol-gen phantom: noise
# keeps it from compressing to nothing) from .nii to .nii.gz, volkit at
# its default level against SimpleITK's WriteImage(useCompression=True)
# (read and write timed inside Python, its import left out), interleaved.
# Target: volkit no slower, its file no more than 2% larger.
if [ -n "$PY" ] && "$PY" -c 'import SimpleITK' 2>/dev/null; then
    GZ="$DIR/gzip"
    mkdir -p "$GZ"
    if [ ! -f "$GZ/head.nii" ]; then
        "$B/vol-gen" phantom --dims "$DIM,$DIM,$((DIM / 2))" --quiet -o "$GZ/head.vvol"
        "$B/vol-convert" "$GZ/head.vvol" -q -o "$GZ/head.nii"
        rm -f "$GZ/head.vvol"
    fi
    : > "$GZ/runs.txt"
    for r in $(seq 1 "$RUNS"); do
        rm -f "$GZ/vk.nii.gz" "$GZ/sitk.nii.gz"
        sync
        read -r v_s v_k v_c < <(timed "$B/vol-convert" "$GZ/head.nii" -q -o "$GZ/vk.nii.gz")
        sync
        s_s=$("$PY" -c 'import sys, time, SimpleITK as s
t = time.perf_counter()
s.WriteImage(s.ReadImage(sys.argv[1]), sys.argv[2], useCompression=True)
print(f"{time.perf_counter() - t:.4f}")' "$GZ/head.nii" "$GZ/sitk.nii.gz")
        echo "$v_s $s_s $v_c" >> "$GZ/runs.txt"
    done
    v_m=$(awk '{print $1}' "$GZ/runs.txt" | median)
    s_m=$(awk '{print $2}' "$GZ/runs.txt" | median)
    v_c=$(awk '{print $3}' "$GZ/runs.txt" | median)
    v_b=$(stat -c %s "$GZ/vk.nii.gz")
    s_b=$(stat -c %s "$GZ/sitk.nii.gz")
    printf '  .nii -> .nii.gz   %6.3f s  cpu %s s  SimpleITK %.3f s: %sx its time (target <= 1), %s bytes = %sx its %s (target <= 1.02); load %s\n' \
        "$v_m" "$v_c" "$s_m" "$(ratio "$v_m" "$s_m")" "$v_b" "$(ratio "$v_b" "$s_b")" "$s_b" "$(cut -d' ' -f1-3 /proc/loadavg)"
else
    echo "  .nii -> .nii.gz: not measured (set PY to a Python with SimpleITK)"
fi
