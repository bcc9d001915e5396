#!/usr/bin/env bash
# Coverage-guided fuzzing of volkit's readers with AFL++ through cargo-afl
# (stable toolchain). The targets are the functions of fuzz/src/lib.rs.
#
#   scripts/fuzz.sh TARGET SECONDS  fuzz one target for SECONDS (a second
#                                   run resumes the first); prints its totals
#   scripts/fuzz.sh seeds           remake the seed corpora with the tools
#   scripts/fuzz.sh save TARGET     minimise what the fuzzer found into
#                                   fuzz/corpus/TARGET; copy crashes and hangs
#                                   to fuzz/regressions/TARGET
#   scripts/fuzz.sh stats           totals of every target fuzzed so far
#   scripts/fuzz.sh list            the targets
#
# Findings live in target/fuzz-out/TARGET (FUZZ_OUT overrides);
# FUZZ_NO_BUILD=1 skips rebuilding the driver. Every run is
# niced to 19: the machine is shared. CI does not fuzz: `cargo test
# --workspace` runs the saved corpora and regressions through the targets.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGETS="vvol thesis raw nrrd mhd tiff vidx tf pfm png scene vpart vidxpart nifti dicom omezarr ometiff envmap csa"
OUT=${FUZZ_OUT:-target/fuzz-out}
BIN=target/fuzz/release/volkit-fuzz
# Corpus files kept per target, and their largest size.
KEEP_MAX=40
KEEP_BYTES=16384

die() { echo "fuzz: $*" >&2; exit 1; }

is_target() { for t in $TARGETS; do [ "$t" = "$1" ] && return 0; done; return 1; }

setup() {
    # FUZZ_NO_BUILD=1: fuzz with the driver as last built (an instrumented
    # build takes tens of minutes on two cores).
    if [ -n "${FUZZ_NO_BUILD:-}" ] && [ -x "$BIN" ]; then
        return 0
    fi
    if ! cargo afl --version >/dev/null 2>&1; then
        echo "fuzz: installing cargo-afl" >&2
        cargo install cargo-afl --locked
    fi
    # Builds AFL++ once per toolchain; says so (and fails) when it exists.
    cargo afl config --build >/dev/null 2>&1 || true
    echo "fuzz: building the instrumented driver" >&2
    CARGO_TARGET_DIR=target/fuzz nice -n 19 cargo afl build --release --quiet \
        -p volkit-fuzz --features afl
}

afl_env() {
    export AFL_SKIP_CPUFREQ=1 AFL_NO_UI=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1
    export AFL_NO_AFFINITY=1
    # Scratch files of the targets on a memory file system when there is one.
    if [ -d /dev/shm ] && [ -w /dev/shm ]; then export TMPDIR=/dev/shm; fi
}

stat_of() { # FILE KEY
    awk -v k="$2" -F' *: *' '$1 == k {print $2}' "$1"
}

# One line per run of a target: its stats after the run. A run resumes the
# one before (-i -), and AFL++ then carries its counters on, so the last
# line of a target holds its totals.
record() { # TARGET
    local s="$OUT/$1/default/fuzzer_stats"
    [ -f "$s" ] || return 0
    printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$1" "$(stat_of "$s" run_time)" \
        "$(stat_of "$s" execs_done)" "$(stat_of "$s" corpus_count)" \
        "$(stat_of "$s" saved_crashes)" "$(stat_of "$s" saved_hangs)" >>"$OUT/runs.tsv"
}

stats() {
    [ -f "$OUT/runs.tsv" ] || die "no runs recorded in $OUT/runs.tsv yet"
    printf 'target\truns\tseconds\texecs\tcorpus\tcrashes\thangs\n'
    awk -F'\t' '{n[$1]++; last[$1]=$2 "\t" $3 "\t" $4 "\t" $5 "\t" $6}
        END {for (t in n) printf "%s\t%d\t%s\n", t, n[t], last[t]}' "$OUT/runs.tsv" | sort
}

fuzz() { # TARGET SECONDS
    local t=$1 secs=$2 in
    is_target "$t" || die "unknown target '$t' (targets: $TARGETS)"
    [[ "$secs" =~ ^[0-9]+$ ]] && [ "$secs" -gt 0 ] || die "SECONDS must be a positive whole number"
    [ -d "fuzz/corpus/$t" ] || die "no seed corpus fuzz/corpus/$t: run scripts/fuzz.sh seeds"
    setup
    afl_env
    mkdir -p "$OUT"
    in="fuzz/corpus/$t"
    if [ -d "$OUT/$t/default/queue" ]; then
        in=-  # resume where the last run stopped
    fi
    # -m: an allocation past 4 GiB fails and aborts, so AFL++ reports it.
    nice -n 19 cargo afl fuzz -V "$secs" -t 2000 -m 4096 -i "$in" -o "$OUT/$t" \
        -- "$BIN" "$t" >"$OUT/$t.log" 2>&1 || {
        tail -20 "$OUT/$t.log" >&2
        die "afl-fuzz failed for $t (log: $OUT/$t.log)"
    }
    record "$t"
    local s="$OUT/$t/default/fuzzer_stats"
    echo "fuzz: $t: $(stat_of "$s" run_time) s, $(stat_of "$s" execs_done) execs," \
        "corpus $(stat_of "$s" corpus_count), crashes $(stat_of "$s" saved_crashes)," \
        "hangs $(stat_of "$s" saved_hangs)"
    local n
    n=$(find "$OUT/$t/default/crashes" "$OUT/$t/default/hangs" -type f -name 'id:*' 2>/dev/null | wc -l)
    if [ "$n" -gt 0 ]; then
        echo "fuzz: $t: $n crashing or hanging inputs in $OUT/$t/default/{crashes,hangs}" >&2
    fi
}

save() { # TARGET
    local t=$1 q="$OUT/$1/default/queue" tmp
    is_target "$t" || die "unknown target '$t'"
    [ -d "$q" ] || die "nothing found for $t yet ($q)"
    afl_env
    # On disk: afl-cmin cannot write its traces under /dev/shm.
    tmp=$(mktemp -d target/fuzz-save.XXXXXX)
    trap 'rm -rf "$tmp"' RETURN
    mkdir -p "$tmp/small"
    find "$q" -maxdepth 1 -type f -size -$((KEEP_BYTES + 1))c -exec cp {} "$tmp/small/" \;
    cp "fuzz/corpus/$t"/* "$tmp/small/" 2>/dev/null || true
    # The shell afl-cmin of the AFL++ that cargo-afl built (its Python
    # variant finds no coverage through this driver).
    local bin
    bin=$(ls -d "$HOME"/.local/share/afl.rs/rustc-"$(rustc --version | awk '{print $2}')"-*/afl.rs-*/afl/bin | tail -1)
    [ -x "$bin/afl-cmin.bash" ] || die "no afl-cmin.bash under ~/.local/share/afl.rs: run a fuzz target first"
    PATH="$bin:$PATH" AFL_PATH="$bin" nice -n 19 bash "$bin/afl-cmin.bash" -t 5000 -m 4096 \
        -i "$tmp/small" -o "$tmp/min" -- "$BIN" "$t" >"$tmp/cmin.log" 2>&1 || { tail -5 "$tmp/cmin.log" >&2;
        die "afl-cmin failed for $t"; }
    rm -rf "fuzz/corpus/$t"
    mkdir -p "fuzz/corpus/$t"
    # The smallest files that still cover every edge cmin kept, named by
    # their content so that saving twice keeps one copy.
    # (sed, not head, reads all of sort's output: head would leave sort
    # writing to a closed pipe, and pipefail fail the save.)
    find "$tmp/min" -type f -printf '%s %p\n' | sort -n | sed -n "1,${KEEP_MAX}p" |
        while read -r _ f; do
            cp "$f" "fuzz/corpus/$t/$(sha1sum "$f" | cut -c1-16)"
        done
    echo "fuzz: $t: kept $(find "fuzz/corpus/$t" -type f | wc -l) corpus files"
    local d
    for d in crashes hangs; do
        for f in "$OUT/$t/default/$d"/id:*; do
            [ -f "$f" ] || continue
            mkdir -p "fuzz/regressions/$t"
            cp "$f" "fuzz/regressions/$t/$(sha1sum "$f" | cut -c1-16)"
        done
    done
}

seeds() {
    local tools=target/debug work
    cargo build --quiet --bins
    work=$(mktemp -d)
    trap 'rm -rf "$work"' RETURN
    local c=fuzz/corpus t
    for t in $TARGETS; do mkdir -p "$c/$t"; done
    local g="$tools/vol-gen" cv="$tools/vol-convert"
    # .vvol: every type and layout, tiny.
    "$g" solid --dims 3,2,2 --value 7 -o "$work/a.vvol" -q && cp "$work/a.vvol" "$c/vvol/u8-sliced"
    "$g" ramp --dims 5,4,3 --type u16 --layout bricked:2 -o "$work/b.vvol" -q && cp "$work/b.vvol" "$c/vvol/u16-bricked"
    "$g" sphere --dims 4,4,4 --type f32 --layout bricked:2 --compress zstd -o "$work/c.vvol" -q &&
        cp "$work/c.vvol" "$c/vvol/f32-zstd"
    "$g" noise --dims 4,3,2 --type i16 -o "$work/d.vvol" -q && cp "$work/d.vvol" "$c/vvol/i16-sliced"
    # Thesis .vol, sliced and bricked.
    "$g" shapes --dims 4,3,2 --count 2 --size 2 -o "$work/a.vol" -q && cp "$work/a.vol" "$c/thesis/sliced"
    "$g" ramp --dims 4,3,3 --layout bricked:3 -o "$work/b.vol" -q && cp "$work/b.vol" "$c/thesis/bricked"
    # Raw: the Open SciVis name on the first line, then the samples.
    for t in u8 u16 i16 f32; do
        "$g" ramp --dims 3,2,2 --type "$t" -o "$work/r_3x2x2_$t.raw" -q
        { printf 'r_3x2x2_%s.raw\n' "$t"; cat "$work/r_3x2x2_$t.raw"; } >"$c/raw/$t"
    done
    # NRRD and MetaImage: headers around samples the tools made.
    "$g" ramp --dims 3,2,2 --type u16 -o "$work/s_3x2x2_u16.raw" -q
    { printf 'NRRD0004\ntype: ushort\ndimension: 3\nsizes: 3 2 2\nspacings: 0.5 0.5 2\nendian: little\nencoding: raw\n\n'
      cat "$work/s_3x2x2_u16.raw"; } >"$c/nrrd/raw"
    { printf 'NRRD0005\n# a comment\ntype: uchar\nsizes: 3 2 2\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nencoding: gzip\nline skip: 0\nbyte skip: 0\nkey:=value\n\n'
      head -c 12 "$work/s_3x2x2_u16.raw" | gzip -c; } >"$c/nrrd/gzip"
    { printf 'NRRD0004\ntype: float\nsizes: 3 2\nendian: big\nencoding: raw\nbyte skip: -1\n\n'
      head -c 24 "$work/s_3x2x2_u16.raw"; } >"$c/nrrd/float-end"
    { printf 'ObjectType = Image\nNDims = 3\nDimSize = 3 2 2\nElementType = MET_USHORT\nElementSpacing = 1 1 2\nBinaryDataByteOrderMSB = False\nElementDataFile = LOCAL\n'
      cat "$work/s_3x2x2_u16.raw"; } >"$c/mhd/raw"
    { printf 'NDims = 2\nDimSize = 3 2\nElementType = MET_UCHAR\nCompressedData = True\nElementDataFile = LOCAL\n'
      head -c 6 "$work/s_3x2x2_u16.raw" | python3 -c 'import sys, zlib; sys.stdout.buffer.write(zlib.compress(sys.stdin.buffer.read()))' 2>/dev/null ||
      head -c 6 "$work/s_3x2x2_u16.raw"; } >"$c/mhd/zlib"
    # TIFF: multipage files of every type, and a BigTIFF.
    for t in u8 u16 i16 f32; do
        "$g" ramp --dims 3,2,2 --type "$t" -o "$work/t-$t.vvol" -q
        "$cv" "$work/t-$t.vvol" -o "$work/t-$t.tif" -q
        cp "$work/t-$t.tif" "$c/tiff/$t"
    done
    cargo run --quiet -p volkit-fuzz --example bigtiff -- "$work/t-u16.vvol" "$c/tiff/bigtiff-u16"
    # Index sidecars.
    "$tools/vol-index" "$work/t-u8.vvol" --cell 2 -o "$work/a.vidx" -q && cp "$work/a.vidx" "$c/vidx/u8"
    "$tools/vol-index" "$work/c.vvol" --cell 2 --bins 8 -o "$work/b.vidx" -q && cp "$work/b.vidx" "$c/vidx/f32"
    # Parts of sharded conversions and index builds (one-shard jobs merge).
    "$cv" "$work/b.vvol" --layout bricked:2 --shard 0/1 -o "$work/a.vpart" -q && cp "$work/a.vpart" "$c/vpart/bricked-1"
    "$cv" "$work/c.vvol" --layout bricked:2 --compress zstd --shard 1/2 -o "$work/b.vpart" -q && cp "$work/b.vpart" "$c/vpart/zstd-1of2"
    "$cv" "$work/a.vvol" --shard 0/1 -o "$work/c.vpart" -q && cp "$work/c.vpart" "$c/vpart/sliced-1"
    "$tools/vol-index" "$work/t-u8.vvol" --cell 2 --shard 0/1 -o "$work/a.vidxpart" -q && cp "$work/a.vidxpart" "$c/vidxpart/u8-1"
    "$tools/vol-index" "$work/c.vvol" --cell 2 --bins 8 --shard 0/2 -o "$work/b.vidxpart" -q && cp "$work/b.vidxpart" "$c/vidxpart/f32-0of2"
    # Transfer functions: the README's example and the noise study's.
    printf 'domain 0 255\nstep 1\nrange 85 95 255 0 0 0.02\npoint 100 0 255 0 0.6\n' >"$c/tf/readme"
    printf '# comment\npoint 0 0 0 0 0\npoint 255 255 255 255 1 # end\n' >"$c/tf/points"
    # Images: renders of a tiny volume, and a difference heat map.
    "$tools/vol-render" "$work/t-u8.vvol" --size 4x3 -o "$work/a.png" --hdr "$work/a.pfm" >/dev/null 2>&1 &&
        cp "$work/a.png" "$c/png/render" && cp "$work/a.pfm" "$c/pfm/render"
    "$tools/vol-psnr" "$work/t-u8.vvol" "$work/t-u16.vvol" --range 1 --diff "$work/d.png" -q 2>/dev/null || true
    [ -f "$work/d.png" ] && cp "$work/d.png" "$c/png/diff"
    printf 'Pf\n2 1\n-1.0\n\0\0\200?\0\0\300\177' >"$c/pfm/grey"
    # Scene files: effective scenes vol-render prints (every kind of
    # light, both effects), and one written by hand.
    local r="$tools/vol-render"
    "$r" "$work/t-u8.vvol" --light 1,2,0.5 --shadows grid:2 --ao 8:3 --print-scene >"$c/scene/shadows-ao"
    "$r" "$work/t-u8.vvol" --mode iso --iso 1 --orbit 10,20,3 --ao-field 16 --print-scene >"$c/scene/iso-field"
    cat >"$c/scene/lights" <<'EOF'
volume = "v.vvol"
tf-text = """
domain 0 255
point 0 0 0 0 0
point 255 255 255 255 1
"""
up = "patient"
ambient = [0.1, 0.2, 0.3]
[[lights]]
type = "point"
position = [1, 2, 3]
intensity = 40
[[lights]]
type = "headlight"
colour = 0.5
EOF
    # NIfTI-1 as vol-convert writes it, plain and gzip.
    "$cv" "$work/t-u16.vvol" -o "$work/a.nii" -q && cp "$work/a.nii" "$c/nifti/u16"
    "$cv" "$work/t-f32.vvol" -o "$work/b.nii.gz" -q && cp "$work/b.nii.gz" "$c/nifti/f32-gz"
    # DICOM: the middle slice of the target's three-slice series.
    cargo run --quiet -p volkit-fuzz --example dicom -- "$c/dicom/slice"
    # The Siemens CSA header of a mosaic (its tile count and slice normal).
    cargo run --quiet -p volkit-fuzz --example csa -- "$c/csa/mosaic"
    # OME-Zarr, NGFF 0.4 and 0.5: group metadata, NUL, array metadata,
    # NUL, chunk 0 (fuzz/src/lib.rs, split_zarr).
    "$cv" "$work/t-u16.vvol" -o "$work/a.ome.zarr" -q
    { cat "$work/a.ome.zarr/.zattrs"; printf '\0'; cat "$work/a.ome.zarr/0/.zarray"; printf '\0'
      cat "$work/a.ome.zarr/0/0/0/0"; } >"$c/omezarr/v2"
    "$cv" "$work/t-u8.vvol" --ngff 0.5 -o "$work/b.ome.zarr" -q
    { cat "$work/b.ome.zarr/zarr.json"; printf '\0'; cat "$work/b.ome.zarr/0/zarr.json"; printf '\0'
      cat "$work/b.ome.zarr/0/c/0/0/0"; } >"$c/omezarr/v3"
    # OME-TIFF and ImageJ descriptions: a layout byte (pages - 1 in the
    # low four bits, sample type in the high), then the text.
    printf '\x13ImageJ=1.54f\nimages=4\nchannels=2\nslices=2\nhyperstack=true\nspacing=2.5\nunit=micron\n' >"$c/ometiff/imagej-cz"
    printf '\x00ImageJ=1.54f\nimages=3\nslices=3\nspacing=0.5\nloop=false\n' >"$c/ometiff/imagej-raw"
    printf '\x25<?xml version="1.0" encoding="UTF-8"?><OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image ID="Image:0"><Pixels ID="Pixels:0" DimensionOrder="XYZCT" Type="float" SizeX="3" SizeY="2" SizeZ="3" SizeC="2" SizeT="1" PhysicalSizeX="0.5" PhysicalSizeY="0.5" PhysicalSizeZ="2"><Channel ID="Channel:0:0"/><Channel ID="Channel:0:1"/></Pixels></Image></OME>' >"$c/ometiff/ome-zc"
    # Environment maps: renders as PFM and (path-traced) OpenEXR, and a
    # grey PFM.
    "$tools/vol-render" "$work/t-u8.vvol" --size 4x2 -o "$work/e.png" --hdr "$work/e.pfm" >/dev/null 2>&1 &&
        cp "$work/e.pfm" "$c/envmap/rgb-pfm"
    "$tools/vol-render" "$work/t-u8.vvol" --mode path --spp 1 --size 4x2 -o "$work/e.png" --hdr "$work/e.exr" >/dev/null 2>&1 &&
        cp "$work/e.exr" "$c/envmap/rgb-exr"
    printf 'Pf\n2 1\n-1.0\n\0\0\200?\0\0\000@' >"$c/envmap/grey"
    for t in $TARGETS; do
        echo "fuzz: seeds for $t: $(find "$c/$t" -type f | wc -l) files"
    done
}

case "${1:-}" in
    list) echo "$TARGETS" ;;
    seeds) seeds ;;
    stats) stats ;;
    save) [ $# -eq 2 ] || die "usage: scripts/fuzz.sh save TARGET"; save "$2" ;;
    ""|-h|--help) sed -n '2,17p' "$0" ;;
    *) [ $# -eq 2 ] || die "usage: scripts/fuzz.sh TARGET SECONDS"; fuzz "$1" "$2" ;;
esac
