#!/usr/bin/env bash
# Benchmark: vol-render's Monte Carlo path tracer (--mode path) against
# Mitsuba 3's volpath integrator, in the same run on the same machine.
# Scenes (128³ u8, made by vol-gen when missing): dense = `vol-gen spheres`
# (almost every voxel busy), sparse = `vol-gen spheres --count 10 --size 20
# --seed 1` (5% of the voxels busy). Extinction sigma_t = value/255 × S per
# world unit (one voxel), albedo 0.8, isotropic phase; a sun travelling
# along (-1,-1.2,0.4) with irradiance 4 and a constant environment of
# radiance 0.1, visible behind the volume; 256x256, 64 spp, box [0, 127]³,
# camera at (249.53,198.92,385.72) looking at the centre, up +y, 45° fov.
# Configurations: dense D=8 and sparse D=8 (default), dense D=1 on request
# (D = real scattering events per path; Mitsuba's max_depth = D+1), S = 0.1
# dense and 1 sparse (where one global majorant wastes most collisions).
# Efficiency (issue 54): 1 / (render time x MSE), the MSE of each 64-spp image
# against a 2048-spp reference rendered by vol-render with --sampler hash
# --transmittance ratio --seed 1000003 (another seed: samples shared with
# the measured images would flatter them; cached in DIR as NAME-ref.pfm;
# REF_SPP), peak 1.0.
# Timing: REPEAT rounds, interleaved (ours as shipped, ours --sampler hash,
# ours --sampler hash --transmittance ratio (the 2026-12-02 method), ours
# --majorant global, Mitsuba, pbrt), THREADS threads each (default 2); the
# peers' render_s excludes their imports, scene loads and (Mitsuba) an
# untimed JIT warm-up render. Reported per renderer: the median render_s,
# the MSE, the efficiency and ours-as-shipped / it.
# Convergence: ours at 16, 64 and 256 spp with each sampler, PSNR against
# the reference and the dB gained per 4x samples (6.02 dB for independent
# samples; QMC may gain more).
# Physics check: ours and Mitsuba at SPP_REF spp (default 1024) once per
# configuration: vol-psnr of ours against Mitsuba (peak 1.0; issue 54: at
# least 45 dB) and the mean of each image.
# Targets (issue 54): efficiency ours/Mitsuba >= 6x and ours/pbrt >= 15x on
# dense D=8; >= 25x both on sparse D=8 (2026-12-02: 4.1x, 12.5x; 23.7x,
# 23.4x).
# Peers, installed here on first use: Mitsuba 3 (../shared/peers/
# mitsuba_volpath.py or scripts/peers/) in a venv at ~/.cache/volkit-peers/
# mitsuba (pip install mitsuba numpy; the llvm variant needs Debian's
# libllvm19, apt-get installed when missing and we are root); pbrt-v4
# (../shared/peers/pbrt.sh build: ~10 min niced on first use; then
# pbrt_volpath.py, run by the venv's python for numpy). A peer that cannot
# run is skipped with the reason.
# A full run takes ~10-15 min on a quiet 2-core machine.
# Usage: scripts/bench-path.sh
#        REPEAT=7 THREADS=1 scripts/bench-path.sh
#        QUICK=1 scripts/bench-path.sh      (1 round, check at 256 spp)
#        PEERS=0 scripts/bench-path.sh      (ours alone)
#        CHECK=0 scripts/bench-path.sh      (no check against Mitsuba)
#        CONFIGS="sparse-d8 dense-d1" scripts/bench-path.sh
#        BUILD=0 (do not run cargo), DIR=out/bench-path (outputs),
#        REF_SPP (2048), MITSUBA_VENV, MITSUBA_VARIANT (default llvm_ad_rgb),
#        PBRT=0 (skip pbrt).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${QUICK:-0}" = 1 ]; then
    REPEAT=${REPEAT:-1}
    SPP_REF=${SPP_REF:-256}
fi
REPEAT=${REPEAT:-5}
SPP_REF=${SPP_REF:-1024}
REF_SPP=${REF_SPP:-2048}
THREADS=${THREADS:-2}
CHECK=${CHECK:-1}
PEERS=${PEERS:-1}
PBRT=${PBRT:-1}
CONFIGS=${CONFIGS:-dense-d8 sparse-d8}
DIR=${DIR:-out/bench-path}
MVENV=${MITSUBA_VENV:-$HOME/.cache/volkit-peers/mitsuba}
MVARIANT=${MITSUBA_VARIANT:-llvm_ad_rgb}
mkdir -p "$DIR"
if [ "${BUILD:-1}" != 0 ]; then
    cargo build --release --quiet --bins
fi
B=${CARGO_TARGET_DIR:-target}/release

DIMS=128,128,128
SPP=64
SIZE=256x256
ALBEDO=0.8
SUN=-1,-1.2,0.4:4
ENV=0.1
CAMERA=("--eye=249.53,198.92,385.72" --look-at "63.5,63.5,63.5" --up "0,1,0" --fov 45)
# name, volume, bounces D, density scale S, efficiency targets ours/Mitsuba and ours/pbrt
ALL_CONFIGS=("dense-d1 dense 1 0.1 - -" "dense-d8 dense 8 0.1 6 15" "sparse-d8 sparse 8 1 25 25")

field() { sed -n "s/.*\"$1\": *\([^,}]*\).*/\1/p"; }
median() { sort -g | awk '{v[NR] = $1} END {if (NR == 0) print "nan"; else if (NR % 2) print v[(NR + 1) / 2]; else print (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
div() { awk -v a="$1" -v b="$2" 'BEGIN {if (b > 0) printf "%.3f\n", a / b; else print "nan"}'; }
need() { # value, what: a figure a tool must have printed
    if [ -z "$1" ]; then
        echo "bench-path: $2 printed no figure (see its output above)" >&2
        exit 1
    fi
    echo "$1"
}
# MSE of an image against a reference (peak 1.0, all channels).
mse() { need "$("$B/vol-psnr" "$1" "$2" --json | field mse)" "vol-psnr $1 $2"; }
# 1 / (seconds x MSE)
eff() { awk -v t="$1" -v m="$2" 'BEGIN {if (t > 0 && m > 0) printf "%.4g\n", 1 / (t * m); else print "nan"}'; }
psnr_of() { awk -v m="$1" 'BEGIN {if (m > 0) printf "%.2f\n", -10 * log(m) / log(10); else print "inf"}'; }

# The volumes: a .vvol for vol-render, the same voxels as a headerless raw
# u8 file (x fastest) for the peers; vol-gen gives the same bytes for the
# same arguments, and vol-psnr confirms the two files hold the same voxels.
declare -A GEN=([dense]="" [sparse]="--count 10 --size 20 --seed 1")
for v in dense sparse; do
    vvol="$DIR/$v.vvol"
    raw="$DIR/${v}_128x128x128_uint8.raw"
    # shellcheck disable=SC2086 # the scene's options, split
    [ -f "$vvol" ] || "$B/vol-gen" spheres --dims "$DIMS" ${GEN[$v]} -o "$vvol" --quiet
    # shellcheck disable=SC2086
    [ -f "$raw" ] || "$B/vol-gen" spheres --dims "$DIMS" ${GEN[$v]} -o "$raw" --quiet
    "$B/vol-psnr" "$vvol" "$raw" --min-psnr inf --quiet ||
        { echo "bench-path: $vvol and $raw hold different voxels (delete them to regenerate)" >&2; exit 1; }
done

# The peers: found, installed on first use, and smoke-tested (a 16x16
# frame) so that a broken install skips their rows instead of failing the
# run.
PEER=0
PBRT_OK=0
MPY="$MVENV/bin/python"
find_peer() {
    for f in "scripts/peers/$1" "../shared/peers/$1"; do
        if [ -f "$f" ]; then
            echo "$f"
            return
        fi
    done
}
MSCRIPT=$(find_peer mitsuba_volpath.py)
PSCRIPT=$(find_peer pbrt_volpath.py)
PBRT_SH=$(find_peer pbrt.sh)
smoke=(--dims "$DIMS" --size 16x16 --spp 1 --threads "$THREADS" "--sun=$SUN" --env "$ENV")
if [ "$PEERS" = 0 ]; then
    echo "peers: skipped (PEERS=0)"
elif [ -z "$MSCRIPT" ]; then
    echo "peer Mitsuba 3: skipped (mitsuba_volpath.py not found in scripts/peers or ../shared/peers)"
else
    if [[ $MVARIANT == llvm* ]] && ! ldconfig -p 2> /dev/null | grep -q 'libLLVM.so.19\|libLLVM-19'; then
        if [ "$(id -u)" = 0 ] && command -v apt-get > /dev/null; then
            echo "installing libllvm19 for Mitsuba's $MVARIANT (log in $DIR/llvm-setup.log)"
            { apt-get update -qq && apt-get install -y -qq libllvm19; } > "$DIR/llvm-setup.log" 2>&1 ||
                echo "    apt-get install libllvm19 failed: $(tail -n 1 "$DIR/llvm-setup.log")"
        fi
    fi
    if [ ! -x "$MPY" ]; then
        echo "setting up Mitsuba 3 in $MVENV (once; log in $DIR/mitsuba-setup.log)"
        fresh=0
        [ -e "$MVENV" ] || fresh=1
        if ! { python3 -m venv "$MVENV" && "$MVENV/bin/pip" install mitsuba numpy; } > "$DIR/mitsuba-setup.log" 2>&1; then
            echo "peer Mitsuba 3: skipped (setup failed: $(tail -n 1 "$DIR/mitsuba-setup.log"); see $DIR/mitsuba-setup.log)"
            # half a venv would look installed next time; only ever remove what this run created
            if [ "$fresh" = 1 ]; then rm -rf "$MVENV" || true; fi
        fi
    fi
    if [ -x "$MPY" ]; then
        if "$MPY" "$MSCRIPT" "$DIR/dense_128x128x128_uint8.raw" "${smoke[@]}" --variant "$MVARIANT" --warmup 0 \
            -o "$DIR/mitsuba-smoke.pfm" > "$DIR/mitsuba-smoke.log" 2>&1; then
            PEER=1
            echo "peer Mitsuba 3: $(field mitsuba < "$DIR/mitsuba-smoke.log" | tail -n 1 | tr -d '"') $MVARIANT, $MSCRIPT"
        else
            echo "peer Mitsuba 3: skipped (a test render failed: $(tail -n 1 "$DIR/mitsuba-smoke.log"));"
            echo "    the llvm variants need libLLVM >= 16 (apt-get install libllvm19), or MITSUBA_VARIANT=scalar_rgb"
        fi
    fi
fi
PBIN=""
if [ "$PEERS" = 0 ]; then
    :
elif [ "$PBRT" = 0 ]; then
    echo "peer pbrt-v4: skipped (PBRT=0)"
elif [ -z "$PSCRIPT" ] || [ -z "$PBRT_SH" ]; then
    echo "peer pbrt-v4: skipped (pbrt_volpath.py or pbrt.sh not found in scripts/peers or ../shared/peers)"
elif [ ! -x "$MPY" ]; then
    echo "peer pbrt-v4: skipped (its script needs numpy, from the Mitsuba venv, which is missing)"
else
    PBIN=$(bash "$PBRT_SH" path)
    if [ ! -x "$PBIN" ]; then
        echo "building pbrt-v4 (once, ~10 min niced; log in $DIR/pbrt-build.log)"
        bash "$PBRT_SH" build > "$DIR/pbrt-build.log" 2>&1 ||
            echo "    pbrt build failed: $(tail -n 1 "$DIR/pbrt-build.log")"
    fi
    if [ -x "$PBIN" ] && "$MPY" "$PSCRIPT" "$DIR/dense_128x128x128_uint8.raw" "${smoke[@]}" --pbrt "$PBIN" \
        -o "$DIR/pbrt-smoke.exr" > "$DIR/pbrt-smoke.log" 2>&1; then
        PBRT_OK=1
        echo "peer pbrt-v4: $PBIN (independent sampler), $PSCRIPT"
    else
        echo "peer pbrt-v4: skipped (no binary, or a test render failed: $(tail -n 1 "$DIR/pbrt-smoke.log" 2> /dev/null))"
    fi
fi
if [ "$CHECK" != 0 ] && [ "$PEER" = 0 ]; then
    echo "physics check: skipped (it compares against Mitsuba)"
fi

ours() { # volume, bounces, scale, spp, output stem, extra options...
    local vol=$1 d=$2 s=$3 spp=$4 stem=$5
    shift 5
    "$B/vol-render" "$vol" --mode path --density-scale "$s" --albedo "$ALBEDO" "--sun=$SUN" --env "$ENV" \
        --spp "$spp" --bounces "$d" --size "$SIZE" "${CAMERA[@]}" --threads "$THREADS" \
        --hdr "$stem.pfm" -o "$stem.png" --json --quiet "$@"
}
peer_flags() { # bounces, scale, spp: the flags both peer scripts share
    PF=(--dims "$DIMS" --sigma-t-scale "$2" --albedo "$ALBEDO" "--sun=$SUN" --env "$ENV" --spp "$3"
        --bounces "$1" --size "$SIZE" --threads "$THREADS" "${CAMERA[@]}")
}
mitsuba() { # raw volume, bounces, scale, spp, output stem, extra options...
    local raw=$1 stem=$5
    peer_flags "$2" "$3" "$4"
    shift 5
    "$MPY" "$MSCRIPT" "$raw" "${PF[@]}" --variant "$MVARIANT" -o "$stem.pfm" --png "$stem.png" "$@"
}
pbrt() { # raw volume, bounces, scale, spp, output stem
    peer_flags "$2" "$3" "$4"
    "$MPY" "$PSCRIPT" "$1" "${PF[@]}" --pbrt "$PBIN" -o "$5.exr"
}
# Means of two PFM images (A = Mitsuba, B = ours): over the whole image, and
# over the pixels where A is not the bare environment (what the volume
# touches). Prints: mean_a mean_b rel_diff_% rel_diff_volume_%.
means() {
    "$MPY" - "$1" "$2" "$ENV" << 'EOF'
import re
import sys

import numpy as np


def pfm(path):
    data = open(path, "rb").read()
    m = re.match(rb"(P[Ff])\s+(\d+)\s+(\d+)\s+(\S+)\s", data)
    if not m:
        sys.exit(f"{path}: not a PFM file")
    c = 3 if m.group(1) == b"PF" else 1
    w, h, scale = int(m.group(2)), int(m.group(3)), float(m.group(4))
    px = np.frombuffer(data, dtype="<f4" if scale < 0 else ">f4", count=w * h * c, offset=m.end())
    return px.reshape(h, w, c).astype(np.float64)


a, b, env = pfm(sys.argv[1]), pfm(sys.argv[2]), float(sys.argv[3])
if a.shape != b.shape:
    sys.exit(f"{sys.argv[1]} is {a.shape}, {sys.argv[2]} is {b.shape}")


def rel(x, y):
    return 100.0 * (y - x) / x if x != 0 else float("nan")


vol = np.abs(a - env).max(axis=2) > 1e-4
va, vb = (a[vol].mean(), b[vol].mean()) if vol.any() else (float("nan"), float("nan"))
print(f"{a.mean():.6f} {b.mean():.6f} {rel(a.mean(), b.mean()):+.3f} {rel(va, vb):+.3f}")
EOF
}

echo "path tracer benchmark: 128^3, ${SIZE}, ${SPP} spp, ${THREADS} thread(s), REPEAT=$REPEAT," \
    "reference ${REF_SPP} spp (ours, --sampler hash --transmittance ratio --seed 1000003), check at ${SPP_REF} spp"
echo "load at start: $(uptime)"
# Our variants: label|options.
VARIANTS=("ours|" "ours-hash|--sampler hash" "ours-2026-12-02|--sampler hash --transmittance ratio"
    "ours-global|--majorant global")
ROWS=()
CONV=()
for cfg in "${ALL_CONFIGS[@]}"; do
    read -r name v d s tm tp <<< "$cfg"
    case " $CONFIGS " in *" $name "*) ;; *) continue ;; esac
    vvol="$DIR/$v.vvol"
    raw="$DIR/${v}_128x128x128_uint8.raw"
    ref="$DIR/$name-ref.pfm"
    echo "== $name: $v volume, D=$d, S=$s"
    if [ ! -f "$ref" ]; then
        echo "   reference: ours at $REF_SPP spp, hash sampler, ratio tracking, seed 1000003 (cached as $ref)"
        ours "$vvol" "$d" "$s" "$REF_SPP" "$DIR/$name-ref" --sampler hash --transmittance ratio \
            --seed 1000003 > /dev/null
    fi
    labels=()
    for var in "${VARIANTS[@]}"; do labels+=("${var%%|*}"); done
    if [ "$PEER" = 1 ]; then labels+=(mitsuba); fi
    if [ "$PBRT_OK" = 1 ]; then labels+=(pbrt); fi
    for l in "${labels[@]}"; do : > "$DIR/$name-$l.txt"; done
    for i in $(seq 1 "$REPEAT"); do
        line="round $i:"
        for var in "${VARIANTS[@]}"; do
            l=${var%%|*}
            # shellcheck disable=SC2086 # the variant's options, split
            j=$(ours "$vvol" "$d" "$s" "$SPP" "$DIR/$name-$l" ${var#*|})
            t=$(need "$(echo "$j" | field render_s)" "vol-render --mode path ($l)")
            echo "$t" >> "$DIR/$name-$l.txt"
            line="$line $l $(printf '%.3f' "$t") s,"
        done
        if [ "$PEER" = 1 ]; then
            if m=$(mitsuba "$raw" "$d" "$s" "$SPP" "$DIR/$name-mitsuba"); then
                mt=$(need "$(echo "$m" | field render_s)" "mitsuba_volpath.py")
                echo "$mt" >> "$DIR/$name-mitsuba.txt"
                fc=$(echo "$m" | field foreign_cpu_s)
                line="$line Mitsuba $mt s (others' CPU meanwhile $fc s$(
                    awk -v f="$fc" -v t="$mt" 'BEGIN {if (f > 0.1 * t) printf ": DISTURBED"}')),"
            else
                echo "peer Mitsuba 3 failed on $name: its rows are skipped from here on"
                PEER=0
            fi
        fi
        if [ "$PBRT_OK" = 1 ]; then
            if p=$(pbrt "$raw" "$d" "$s" "$SPP" "$DIR/$name-pbrt"); then
                pt=$(need "$(echo "$p" | field render_s)" "pbrt_volpath.py")
                echo "$pt" >> "$DIR/$name-pbrt.txt"
                line="$line pbrt $pt s"
            else
                echo "peer pbrt-v4 failed on $name: its rows are skipped from here on"
                PBRT_OK=0
            fi
        fi
        echo "$line"
    done
    # Per renderer: the median time, the MSE of its last image (ours are the
    # same bytes every round), the efficiency, and ours (as shipped) / it.
    declare -A T=() M=() E=()
    for l in "${labels[@]}"; do
        [ -s "$DIR/$name-$l.txt" ] || continue
        T[$l]=$(median < "$DIR/$name-$l.txt")
        img="$DIR/$name-$l.pfm"
        if [ "$l" = pbrt ]; then img="$DIR/$name-pbrt.exr"; fi
        M[$l]=$(mse "$ref" "$img")
        E[$l]=$(eff "${T[$l]}" "${M[$l]}")
    done
    for l in "${labels[@]}"; do
        [ -n "${T[$l]:-}" ] || continue
        ratio=$(div "${E[ours]}" "${E[$l]}")
        target="–"
        goal=""
        case $l in
            mitsuba) goal=$tm ;;
            pbrt) goal=$tp ;;
        esac
        if [ -n "$goal" ] && [ "$goal" != - ]; then
            target="≥ ${goal}x: $(awk -v r="$ratio" -v t="$goal" 'BEGIN {print (r >= t) ? "met" : "MISSED"}')"
        fi
        ROWS+=("| $name | $l | ${T[$l]} | ${M[$l]} | $(psnr_of "${M[$l]}") | ${E[$l]} | ${ratio}x | $target |")
        echo "   $l: median ${T[$l]} s, MSE ${M[$l]} ($(psnr_of "${M[$l]}") dB), efficiency ${E[$l]}, ours/$l ${ratio}x $target"
    done
    unset T M E
    # Convergence per 4x samples, each sampler. The reference has noise of
    # its own (at 256 spp, an eighth of the image's for independent samples).
    for smp in hash sobol; do
        ps=()
        for n in 16 64 256; do
            ours "$vvol" "$d" "$s" "$n" "$DIR/$name-c$n" --sampler "$smp" > /dev/null
            ps+=("$(psnr_of "$(mse "$ref" "$DIR/$name-c$n.pfm")")")
        done
        g1=$(awk -v a="${ps[0]}" -v b="${ps[1]}" 'BEGIN {printf "%+.2f", b - a}')
        g2=$(awk -v a="${ps[1]}" -v b="${ps[2]}" 'BEGIN {printf "%+.2f", b - a}')
        echo "   convergence, --sampler $smp: 16 spp ${ps[0]} dB, 64 spp ${ps[1]} dB ($g1), 256 spp ${ps[2]} dB ($g2)"
        CONV+=("| $name | $smp | ${ps[0]} | ${ps[1]} | ${ps[2]} | $g1 | $g2 |")
    done
    if [ "$CHECK" != 0 ] && [ "$PEER" = 1 ]; then
        ours "$vvol" "$d" "$s" "$SPP_REF" "$DIR/$name-ours-check" > /dev/null
        mitsuba "$raw" "$d" "$s" "$SPP_REF" "$DIR/$name-mitsuba-check" --warmup 0 > /dev/null
        pj=$("$B/vol-psnr" "$DIR/$name-mitsuba-check.pfm" "$DIR/$name-ours-check.pfm" --json)
        psnr=$(need "$(echo "$pj" | field psnr)" "vol-psnr")
        [ "$psnr" = null ] && psnr=inf
        read -r ma mb dmean dvol <<< "$(means "$DIR/$name-mitsuba-check.pfm" "$DIR/$name-ours-check.pfm")"
        pok=$(awk -v p="$psnr" 'BEGIN {print (p == "inf" || p >= 45) ? "met" : "MISSED"}')
        mok=$(awk -v d="$dmean" 'BEGIN {print (d <= 1 && d >= -1) ? "met" : "MISSED"}')
        printf '   check at %s spp: ours vs Mitsuba %.2f dB (>= 45: %s); means Mitsuba %s, ours %s: %s%% (within 1%%: %s); over the volume'"'"'s pixels %s%%\n' \
            "$SPP_REF" "$psnr" "$pok" "$ma" "$mb" "$dmean" "$mok" "$dvol"
    fi
done
echo "load at end: $(uptime)"
{
    echo
    echo "| config | renderer | median s | MSE | PSNR dB | efficiency 1/(s·MSE) | ours / it | target |"
    echo "|---|---|---|---|---|---|---|---|"
    printf '%s\n' "${ROWS[@]}"
    echo
    echo "| config | sampler | 16 spp dB | 64 spp dB | 256 spp dB | 16→64 | 64→256 |"
    echo "|---|---|---|---|---|---|---|"
    printf '%s\n' "${CONV[@]}"
} | tee "$DIR/summary.md"
