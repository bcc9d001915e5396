#!/usr/bin/env bash
# Benchmark: vol-convert's preprocessing stages against SimpleITK and unu
# (issue 52's speed and memory targets). Input: a 512x512x300 i16 CT-like
# head (vol-gen phantom) at 0.5x0.5x2 mm, NIfTI in and NIfTI out. Each
# operation, interleaved (A B C A B C ...), RUNS times, medians:
#   vol-convert ct.nii --resample spacing:1 -o out.nii   (linear, the default)
#     vs SimpleITK ReadImage, ResampleImageFilter (sitkLinear) to the same
#        grid (the issue's convention: dims round(extent/1), box centred),
#        WriteImage                                      target >= 2x
#     vs unu resample -k tent -c cell to the same dims  target >= 4x
#        (unu reads and writes NRRD, not NIfTI: it gets ct.nrrd, the same
#        samples, and writes out.nrrd; teem is single-threaded)
#   vol-convert ct.nii --smooth gauss:1 -o out.nii
#     vs SimpleITK SmoothingRecursiveGaussian(sigma=1 mm) target >= 1x
#   vol-convert ct.nii --median 1 -o out.nii
#     vs SimpleITK Median(radius 1)                      target >= 2x
# vol-convert runs on every core (rayon), SimpleITK on THREADS (default 2,
# sitk.ProcessObject.SetGlobalDefaultNumberOfThreads). Times are wall
# seconds of the whole process for vol-convert and unu; SimpleITK's are
# from ReadImage to WriteImage inside Python (its start and import left
# out, which favours it; the process's wall time is in the runs file).
# Peak resident memory of every process from GNU time (/usr/bin/time).
# Then the memory check: a 1024^3 u8 .vvol resampled to spacing 1.5 must
# peak below 400 MB resident (MEM=0 skips it; it writes a 1 GiB input):
# GNU time's peak, and the anonymous and file-backed (a mapped input)
# parts of it sampled from /proc.
# Peers: SimpleITK in a venv at ~/.cache/volkit-peers/sitk set up here on
# first use (pip install SimpleITK), or PY=python-with-SimpleITK; unu
# from Debian's teem-apps (apt-get install teem-apps: teem-unu), or
# UNU=path. A missing peer is skipped with the reason.
# Usage: scripts/bench-resample.sh [RUNS]   (default 5)
#        DIR=out/bench-resample, BUILD=0 (no cargo), MEM=0, THREADS=2,
#        DIMS=512,512,300 (a smaller volume for a smoke run).
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-5}
DIR=${DIR:-out/bench-resample}
THREADS=${THREADS:-2}
DIMS=${DIMS:-512,512,300}
MEM=${MEM:-1}
SVENV=${SVENV:-$HOME/.cache/volkit-peers/sitk}
mkdir -p "$DIR"
if [ "${BUILD:-1}" = 1 ]; then
    cargo build --release --quiet --bin vol-gen --bin vol-convert
fi
B=${CARGO_TARGET_DIR:-target}/release
[ -x /usr/bin/time ] || { echo "needs GNU time at /usr/bin/time (apt-get install time)"; exit 1; }
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
load() { awk '{print $1, $2, $3}' /proc/loadavg; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN {if (b > 0) printf "%.2f", a / b; else print "-"}'; }
mib() { awk -v k="$1" 'BEGIN {printf "%.0f", k / 1024}'; }

# Run a command under GNU time; sets T_S (wall s), T_K (peak resident
# KiB), T_C (user + system s). A failing command stops the script with
# its last line of stderr.
timed() {
    local t0
    t0=$(date +%s.%N)
    if ! /usr/bin/time -f '%e %M %U %S' -o "$DIR/time.txt" "$@" > "$DIR/cmd.out" 2> "$DIR/cmd.err"; then
        echo "failed: $*: $(grep -v 'Command exited' "$DIR/cmd.err" | tail -n 1)" >&2
        return 1
    fi
    # Wall time from the clock (GNU time's %e has 10 ms steps).
    read -r T_S T_K T_C < <(awk -v a="$t0" -v b="$(date +%s.%N)" '{printf "%.3f %d %.2f\n", b - a, $2, $3 + $4}' "$DIR/time.txt")
}

# --- peers ---------------------------------------------------------------
PY=${PY:-$SVENV/bin/python}
if ! "$PY" -c 'import SimpleITK' 2>/dev/null && [ "$PY" = "$SVENV/bin/python" ]; then
    echo "setting up SimpleITK in $SVENV (once; log in $DIR/sitk-setup.log)"
    fresh=0
    [ -e "$SVENV" ] || fresh=1
    if ! { python3 -m venv "$SVENV" && "$SVENV/bin/pip" install SimpleITK; } > "$DIR/sitk-setup.log" 2>&1; then
        echo "  setup failed: $(tail -n 1 "$DIR/sitk-setup.log")"
        # half a venv would look installed next time; only remove what this run created
        if [ "$fresh" = 1 ]; then rm -rf "$SVENV" || true; fi
    fi
fi
SITK=0
if "$PY" -c 'import SimpleITK' 2>/dev/null; then
    SITK=1
    echo "peer SimpleITK $("$PY" -c 'import SimpleITK as s; print(s.Version.VersionString())') ($PY), $THREADS threads"
else
    echo "peer SimpleITK: skipped ($PY cannot import SimpleITK: set PY, or pip install SimpleITK)"
fi
UNU=${UNU:-$(command -v unu || command -v teem-unu || true)}
if [ -n "$UNU" ] && "$UNU" about > /dev/null 2>&1; then
    echo "peer unu: $UNU (teem $("$UNU" about 2>&1 | grep -o 'Teem version [^ ,]*' | head -n 1 | cut -d' ' -f3))"
else
    echo "peer unu: skipped (not found: apt-get install teem-apps, or set UNU)"
    UNU=""
fi

# --- input ---------------------------------------------------------------
IFS=, read -r NX NY NZ <<< "$DIMS"
CT="$DIR/ct-${NX}x${NY}x${NZ}"
if [ ! -f "$CT.nii" ] || [ ! -f "$CT.nrrd" ]; then
    "$B/vol-gen" phantom --dims "$DIMS" --spacing 0.5,0.5,2 --quiet -o "$CT.vvol"
    "$B/vol-convert" "$CT.vvol" -q -o "$CT.nii"
    "$B/vol-convert" "$CT.vvol" -q -o "$CT.nrrd"
    rm -f "$CT.vvol"
fi
# The 1 mm grid by the issue's convention: dims round(n * s / 1).
RX=$(awk -v n="$NX" 'BEGIN {printf "%d", n * 0.5 + 0.5}')
RY=$(awk -v n="$NY" 'BEGIN {printf "%d", n * 0.5 + 0.5}')
RZ=$(awk -v n="$NZ" 'BEGIN {printf "%d", n * 2 + 0.5}')

cat > "$DIR/sitk_op.py" <<'EOF'
# bench-resample.sh's SimpleITK side: ReadImage, the operation, WriteImage;
# prints the seconds from before ReadImage to after WriteImage.
import sys, time
import SimpleITK as sitk
op, src, dst, threads = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
sitk.ProcessObject.SetGlobalDefaultNumberOfThreads(threads)
t = time.perf_counter()
img = sitk.ReadImage(src)
if op == "resample":
    # The issue's grid: the box from the first voxel's outer face to the
    # last's, dims round(extent / 1 mm), the new box centred on the old.
    n, s, o = img.GetSize(), img.GetSpacing(), img.GetOrigin()
    d = img.GetDirection()
    m = [max(1, round(n[a] * s[a] / 1.0)) for a in range(3)]
    shift = [(n[a] - 1) * s[a] / 2 - (m[a] - 1) * 1.0 / 2 for a in range(3)]
    origin = [o[r] + sum(d[3 * r + a] * shift[a] for a in range(3)) for r in range(3)]
    f = sitk.ResampleImageFilter()
    f.SetSize(m)
    f.SetOutputSpacing([1.0, 1.0, 1.0])
    f.SetOutputOrigin(origin)
    f.SetOutputDirection(d)
    f.SetInterpolator(sitk.sitkLinear)
    f.SetDefaultPixelValue(0)
    out = f.Execute(img)
elif op == "smooth":
    out = sitk.SmoothingRecursiveGaussian(img, 1.0)
elif op == "median":
    out = sitk.Median(img, [1, 1, 1])
else:
    raise SystemExit(f"unknown op {op}")
sitk.WriteImage(out, dst)
print(f"{time.perf_counter() - t:.4f}")
EOF

# --- runs ----------------------------------------------------------------
OPS=(resample smooth median)
declare -A FLAG=([resample]="--resample spacing:1" [smooth]="--smooth gauss:1" [median]="--median 1")
printf '%sx%sx%s i16 phantom at 0.5x0.5x2 mm (%s bytes of NIfTI), %s runs interleaved, %s cores\n' \
    "$NX" "$NY" "$NZ" "$(stat -c %s "$CT.nii")" "$RUNS" "$(nproc)"
LOAD_BEFORE=$(load)
echo "load average before: $LOAD_BEFORE"
: > "$DIR/runs.txt"
for r in $(seq 1 "$RUNS"); do
    for op in "${OPS[@]}"; do
        rm -f "$DIR/vk.nii" "$DIR/sitk.nii" "$DIR/unu.nrrd"
        # shellcheck disable=SC2086
        timed "$B/vol-convert" "$CT.nii" ${FLAG[$op]} -q -o "$DIR/vk.nii"
        echo "$r $op volkit $T_S $T_K $T_C" >> "$DIR/runs.txt"
        if [ "$SITK" = 1 ]; then
            timed "$PY" "$DIR/sitk_op.py" "$op" "$CT.nii" "$DIR/sitk.nii" "$THREADS"
            echo "$r $op SimpleITK $(cat "$DIR/cmd.out") $T_K $T_C $T_S" >> "$DIR/runs.txt"
        fi
        if [ "$op" = resample ] && [ -n "$UNU" ]; then
            timed "$UNU" resample -i "$CT.nrrd" -s "$RX" "$RY" "$RZ" -k tent -c cell -o "$DIR/unu.nrrd"
            echo "$r $op unu $T_S $T_K $T_C" >> "$DIR/runs.txt"
        fi
    done
    printf '  run %s done (load %s)\n' "$r" "$(load)"
done
LOAD_AFTER=$(load)
echo "load average after: $LOAD_AFTER"
# Median of column $3 (1-based, after run/op/tool) for one op and tool.
med() { awk -v op="$1" -v t="$2" -v c="$3" '$2 == op && $3 == t {print $c}' "$DIR/runs.txt" | median; }
has() { awk -v op="$1" -v t="$2" '$2 == op && $3 == t {n++} END {print n + 0}' "$DIR/runs.txt"; }
declare -A TARGET=([resample]=2 [smooth]=1 [median]=2)
declare -A NAME=([resample]="\`--resample spacing:1\` (linear)" [smooth]="\`--smooth gauss:1\`" [median]="\`--median 1\`")
declare -A PNAME=([resample]="ResampleImageFilter linear" [smooth]="SmoothingRecursiveGaussian(1)" [median]="Median(1)")
echo
echo "| operation | volkit s (peak MiB) | peer | peer s (peak MiB) | speed-up | target |"
echo "|---|---|---|---|---|---|"
JSON=""
for op in "${OPS[@]}"; do
    v=$(med "$op" volkit 4); vk=$(med "$op" volkit 5)
    if [ "$(has "$op" SimpleITK)" -gt 0 ]; then
        s=$(med "$op" SimpleITK 4); sk=$(med "$op" SimpleITK 5)
        printf '| %s | %.3f (%s) | SimpleITK %s, %s threads | %.3f (%s) | %sx | >= %sx |\n' \
            "${NAME[$op]}" "$v" "$(mib "$vk")" "${PNAME[$op]}" "$THREADS" "$s" "$(mib "$sk")" "$(ratio "$s" "$v")" "${TARGET[$op]}"
        JSON+="\"${op}_sitk_s\":$s,\"${op}_sitk_peak_kib\":$sk,"
    else
        printf '| %s | %.3f (%s) | SimpleITK: not measured | - | - | >= %sx |\n' "${NAME[$op]}" "$v" "$(mib "$vk")" "${TARGET[$op]}"
    fi
    if [ "$(has "$op" unu)" -gt 0 ]; then
        u=$(med "$op" unu 4); uk=$(med "$op" unu 5)
        printf '| %s | %.3f (%s) | unu resample -k tent, NRRD, 1 thread | %.3f (%s) | %sx | >= 4x |\n' \
            "${NAME[$op]}" "$v" "$(mib "$vk")" "$u" "$(mib "$uk")" "$(ratio "$u" "$v")"
        JSON+="\"${op}_unu_s\":$u,\"${op}_unu_peak_kib\":$uk,"
    fi
    JSON+="\"${op}_s\":$v,\"${op}_peak_kib\":$vk,"
done
echo
echo "SimpleITK's times are ReadImage to WriteImage inside Python; its whole process (start, import) took:"
for op in "${OPS[@]}"; do
    [ "$(has "$op" SimpleITK)" -gt 0 ] && printf '  %s: %.2f s\n' "$op" "$(med "$op" SimpleITK 7)"
done
echo "load average: before $LOAD_BEFORE, after $LOAD_AFTER; $(nproc) cores, $(grep -m 1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"

# --- memory --------------------------------------------------------------
MEMJSON=""
if [ "$MEM" = 1 ]; then
    BIG="$DIR/big-1024.vvol"
    if [ ! -f "$BIG" ]; then
        "$B/vol-gen" spheres --dims 1024,1024,1024 --seed 3 --count 36 --size 128 --quiet -o "$BIG"
    fi
    rm -f "$DIR/big-15.vvol"
    # GNU time's peak counts the pages of a memory-mapped input as they are
    # read (the page cache, shared and reclaimable); sample the anonymous
    # and file-backed parts of the resident set apart from /proc as well.
    "$B/vol-convert" "$BIG" --resample spacing:1.5 -q -o "$DIR/big-15.vvol" &
    pid=$!
    anon=0 file=0
    while kill -0 "$pid" 2> /dev/null; do
        read -r a f < <(awk '/RssAnon/ {a = $2} /RssFile/ {f = $2} END {print a + 0, f + 0}' "/proc/$pid/status" 2> /dev/null || echo "0 0")
        [ "${a:-0}" -gt "$anon" ] && anon=$a
        [ "${f:-0}" -gt "$file" ] && file=$f
        sleep 0.01
    done
    wait "$pid"
    rm -f "$DIR/big-15.vvol"
    timed "$B/vol-convert" "$BIG" --resample spacing:1.5 -q -o "$DIR/big-15.vvol"
    m_s=$T_S m_k=$T_K m_c=$T_C
    mb() { awk -v k="$1" 'BEGIN {printf "%.0f", k * 1024 / 1e6}'; }
    verdict() { awk -v k="$1" 'BEGIN {print (k * 1024 < 400e6) ? "below" : "ABOVE"}'; }
    printf '\nmemory: 1024^3 u8 .vvol --resample spacing:1.5 (to 683^3): %.1f s, cpu %s s\n' "$m_s" "$m_c"
    printf '  peak resident (GNU time) %s MB: %s the 400 MB target\n' "$(mb "$m_k")" "$(verdict "$m_k")"
    printf '  of which, sampled every 10 ms: anonymous %s MB (%s 400 MB), file-backed %s MB (the mapped input, page cache)\n' \
        "$(mb "$anon")" "$(verdict "$anon")" "$(mb "$file")"
    MEMJSON="\"mem_s\":$m_s,\"mem_peak_kib\":$m_k,\"mem_anon_kib\":$anon,\"mem_file_kib\":$file,"
    rm -f "$DIR/big-15.vvol"
fi
printf '{"bench":"resample","dims":"%s","runs":%s,%s%s"load_before":"%s","load_after":"%s"}\n' \
    "$DIMS" "$RUNS" "$JSON" "$MEMJSON" "$LOAD_BEFORE" "$LOAD_AFTER" > "$DIR/resample.json"
echo "wrote $DIR/runs.txt and $DIR/resample.json"
