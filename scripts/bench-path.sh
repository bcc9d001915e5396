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
# Configurations: dense D=1 (single scattering), dense D=8 and sparse D=8
# (D = real scattering events per path; Mitsuba's max_depth = D+1), S = 0.1
# dense and 1 sparse (where one global majorant wastes most collisions).
# Timing: REPEAT pairs, interleaved (ours, Mitsuba, ours with --majorant
# global, ours, Mitsuba, ...), THREADS threads each (default 2); Mitsuba's
# render_s excludes its import, scene load and an untimed warm-up (JIT)
# render. Reported: the median render_s of each, the median of the per-pair
# ratios Mitsuba/ours, and what the majorant grid buys (global / grid).
# Physics check: both at SPP_REF spp (default 1024) once per configuration:
# vol-psnr of ours against Mitsuba (peak 1.0) and the mean of each image.
# Targets: Mitsuba/ours >= 2x dense, >= 5x sparse; PSNR >= 35 dB and image
# means within 1% (the mean over the pixels the volume touches is printed
# beside it). Mitsuba 3.9.1 llvm_ad_rgb on this machine class, 2 threads,
# load < 1 (2026-11-29): 1.2-1.5 s, 3.3-4.0 s and 7.7-8.4 s; at 1024 spp
# two Mitsuba renders differ by ~47-54 dB, so 35 dB leaves room for noise.
# Peer: ../shared/peers/mitsuba_volpath.py (or scripts/peers/), in a venv at
# ~/.cache/volkit-peers/mitsuba set up here on first use (pip install
# mitsuba numpy); the llvm variant needs Debian's libllvm19 (apt-get install
# libllvm19). If the peer cannot run, its rows are skipped with the reason.
# A full run takes ~6-10 min on a quiet 2-core machine (the check ~4 of them).
# Usage: scripts/bench-path.sh
#        REPEAT=7 THREADS=1 scripts/bench-path.sh
#        QUICK=1 scripts/bench-path.sh      (1 pair, check at 256 spp)
#        PEERS=0 scripts/bench-path.sh      (ours alone: no ratios, no check)
#        CHECK=0 scripts/bench-path.sh      (timing only)
#        CONFIGS="sparse-d8" scripts/bench-path.sh   (some configurations)
#        BUILD=0 (do not run cargo), DIR=out/bench-path (outputs),
#        MITSUBA_VENV, MITSUBA_VARIANT (default llvm_ad_rgb).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${QUICK:-0}" = 1 ]; then
    REPEAT=${REPEAT:-1}
    SPP_REF=${SPP_REF:-256}
fi
REPEAT=${REPEAT:-5}
SPP_REF=${SPP_REF:-1024}
THREADS=${THREADS:-2}
CHECK=${CHECK:-1}
PEERS=${PEERS:-1}
CONFIGS=${CONFIGS:-dense-d1 dense-d8 sparse-d8}
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
# name, volume, bounces D, density scale S, speed target (Mitsuba/ours)
ALL_CONFIGS=("dense-d1 dense 1 0.1 2" "dense-d8 dense 8 0.1 2" "sparse-d8 sparse 8 1 5")

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

# The volumes: a .vvol for vol-render, the same voxels as a headerless raw
# u8 file (x fastest) for Mitsuba; vol-gen gives the same bytes for the same
# arguments, and vol-psnr confirms the two files hold the same voxels.
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

# The peer: found, installed on first use, and smoke-tested (a 16x16 frame)
# so that a broken install skips its rows instead of failing the run.
PEER=0
MPY="$MVENV/bin/python"
MSCRIPT=""
for f in scripts/peers/mitsuba_volpath.py ../shared/peers/mitsuba_volpath.py; do
    if [ -f "$f" ]; then MSCRIPT=$f; break; fi
done
if [ "$PEERS" = 0 ]; then
    echo "peer Mitsuba 3: skipped (PEERS=0)"
elif [ -z "$MSCRIPT" ]; then
    echo "peer Mitsuba 3: skipped (mitsuba_volpath.py not found in scripts/peers or ../shared/peers)"
else
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
        if "$MPY" "$MSCRIPT" "$DIR/dense_128x128x128_uint8.raw" --dims "$DIMS" --size 16x16 --spp 1 \
            --variant "$MVARIANT" --threads "$THREADS" --warmup 0 "--sun=$SUN" --env "$ENV" \
            -o "$DIR/mitsuba-smoke.pfm" > "$DIR/mitsuba-smoke.log" 2>&1; then
            PEER=1
            echo "peer Mitsuba 3: $(field mitsuba < "$DIR/mitsuba-smoke.log" | tail -n 1 | tr -d '"') $MVARIANT, $MSCRIPT"
        else
            echo "peer Mitsuba 3: skipped (a test render failed: $(tail -n 1 "$DIR/mitsuba-smoke.log"));"
            echo "    the llvm variants need libLLVM >= 16 (apt-get install libllvm19), or MITSUBA_VARIANT=scalar_rgb"
        fi
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
mitsuba() { # raw volume, bounces, scale, spp, output stem, extra options...
    local raw=$1 d=$2 s=$3 spp=$4 stem=$5
    shift 5
    "$MPY" "$MSCRIPT" "$raw" --dims "$DIMS" --variant "$MVARIANT" --sigma-t-scale "$s" --albedo "$ALBEDO" \
        "--sun=$SUN" --env "$ENV" --spp "$spp" --bounces "$d" --size "$SIZE" "${CAMERA[@]}" \
        --threads "$THREADS" -o "$stem.pfm" --png "$stem.png" "$@"
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

echo "path tracer benchmark: 128^3, ${SIZE}, ${SPP} spp, ${THREADS} thread(s), REPEAT=$REPEAT, check at ${SPP_REF} spp"
echo "load at start: $(uptime)"
ROWS=()
for cfg in "${ALL_CONFIGS[@]}"; do
    read -r name v d s target <<< "$cfg"
    case " $CONFIGS " in *" $name "*) ;; *) continue ;; esac
    vvol="$DIR/$v.vvol"
    raw="$DIR/${v}_128x128x128_uint8.raw"
    : > "$DIR/$name-ours.txt"
    : > "$DIR/$name-mitsuba.txt"
    : > "$DIR/$name-ratio.txt"
    : > "$DIR/$name-global.txt"
    echo "== $name: $v volume, D=$d, S=$s"
    for i in $(seq 1 "$REPEAT"); do
        j=$(ours "$vvol" "$d" "$s" "$SPP" "$DIR/$name-ours")
        echo "$j" > "$DIR/$name-ours-$i.json"
        o=$(need "$(echo "$j" | field render_s)" "vol-render --mode path")
        echo "$o $i" >> "$DIR/$name-ours.txt"
        line="pair $i: ours $o s"
        if [ "$PEER" = 1 ]; then
            if m=$(mitsuba "$raw" "$d" "$s" "$SPP" "$DIR/$name-mitsuba"); then
                echo "$m" > "$DIR/$name-mitsuba-$i.json"
                mt=$(need "$(echo "$m" | field render_s)" "mitsuba_volpath.py")
                echo "$mt" >> "$DIR/$name-mitsuba.txt"
                div "$mt" "$o" >> "$DIR/$name-ratio.txt"
                fc=$(echo "$m" | field foreign_cpu_s)
                line="$line, Mitsuba $mt s (warm-up $(echo "$m" | field warmup_s) s, others' CPU meanwhile $fc s$(
                    awk -v f="$fc" -v t="$mt" 'BEGIN {if (f > 0.1 * t) printf ": DISTURBED"}')), ratio $(div "$mt" "$o")x"
            else
                echo "peer Mitsuba 3 failed on $name: its rows are skipped from here on"
                PEER=0
            fi
        fi
        g=$(ours "$vvol" "$d" "$s" "$SPP" "$DIR/$name-ours-global" --majorant global)
        gt=$(need "$(echo "$g" | field render_s)" "vol-render --mode path --majorant global")
        echo "$gt" >> "$DIR/$name-global.txt"
        echo "$line, ours --majorant global $gt s"
    done
    om=$(cut -d' ' -f1 "$DIR/$name-ours.txt" | median)
    gm=$(median < "$DIR/$name-global.txt")
    # per-path figures from our median run (the middle one by render_s)
    mid=$(sort -g "$DIR/$name-ours.txt" | sed -n "$(((REPEAT + 1) / 2))p" | cut -d' ' -f2)
    oj="$DIR/$name-ours-$mid.json"
    pps=$(field paths_per_s_per_core < "$oj")
    lpp=$(field lookups_per_path < "$oj")
    echo "   ours: median $om s; $(field paths < "$oj") paths, $(field real_collisions < "$oj") real and" \
        "$(field null_collisions < "$oj") null collisions, $(field majorant_cells < "$oj") majorant cells," \
        "$(field density_lookups < "$oj") density lookups"
    echo "   ours --majorant global: median $gm s ($(div "$gm" "$om")x the majorant grid's)"
    mm="–" ratio="–" verdict="≥ ${target}x"
    if [ -s "$DIR/$name-ratio.txt" ]; then
        mm=$(median < "$DIR/$name-mitsuba.txt")
        ratio=$(median < "$DIR/$name-ratio.txt")
        range="$(sort -g "$DIR/$name-ratio.txt" | sed -n '1p;$p' | paste -sd- -)"
        met=$(awk -v r="$ratio" -v t="$target" 'BEGIN {print (r >= t) ? "met" : "MISSED"}')
        verdict="≥ ${target}x: $met"
        echo "   Mitsuba: median $mm s; Mitsuba/ours median ${ratio}x (pairs $range), target $verdict"
        ratio="${ratio}x"
    fi
    psnr="–" mo="–" mmean="–"
    if [ "$CHECK" != 0 ] && [ "$PEER" = 1 ]; then
        ours "$vvol" "$d" "$s" "$SPP_REF" "$DIR/$name-ours-ref" > /dev/null
        mitsuba "$raw" "$d" "$s" "$SPP_REF" "$DIR/$name-mitsuba-ref" --warmup 0 > /dev/null
        pj=$("$B/vol-psnr" "$DIR/$name-mitsuba-ref.pfm" "$DIR/$name-ours-ref.pfm" --json)
        psnr=$(need "$(echo "$pj" | field psnr)" "vol-psnr")
        [ "$psnr" = null ] && psnr=inf
        mres=$(means "$DIR/$name-mitsuba-ref.pfm" "$DIR/$name-ours-ref.pfm")
        read -r ma mb dmean dvol <<< "$mres"
        pok=$(awk -v p="$psnr" 'BEGIN {print (p == "inf" || p >= 35) ? "met" : "MISSED"}')
        mok=$(awk -v d="$dmean" 'BEGIN {print (d <= 1 && d >= -1) ? "met" : "MISSED"}')
        printf '   check at %s spp: PSNR %.2f dB (>= 35: %s); means Mitsuba %s, ours %s: %s%% (within 1%%: %s); over the volume'"'"'s pixels %s%%\n' \
            "$SPP_REF" "$psnr" "$pok" "$ma" "$mb" "$dmean" "$mok" "$dvol"
        psnr=$(printf '%.2f (%s)' "$psnr" "$pok")
        mo="$mb"
        mmean="$ma ($dmean%: $mok)"
    fi
    ROWS+=("| $name | $om | $mm | $ratio | $verdict | $psnr | $mo | $mmean | $pps | $lpp | $gm s ($(div "$gm" "$om")x) |")
done
echo "load at end: $(uptime)"
{
    echo
    echo "| config | ours median s | Mitsuba median s | ratio | target | PSNR dB | mean ours | mean Mitsuba | paths/s/core | lookups/path | global-majorant time |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|"
    printf '%s\n' "${ROWS[@]}"
} | tee "$DIR/summary.md"
