#!/usr/bin/env bash
# Benchmark: vol-view's interactivity in Chromium (Playwright), on the
# issue's volumes: a dense 512³ `vol-gen shapes` (tf grey) and the
# MNI brain (Debian mricron-data's ch2.nii.gz, tf auto), a 512x512 view,
# Phong shading.
# Per volume and build: the first full frame, previews per second of a 1 s
# drag, input-to-pixels while dragging (median) and the full frame after
# the release, medians of REPEAT rounds alternating between the builds.
# Targets (issue 54, 2 cores): at least 15 previews/s, median at most
# 100 ms, the full frame within 0.7 s of the release, the first within 1 s.
#
#   scripts/bench-view.sh                         # this tree's build alone
#   BASE=/work/bt-old/release scripts/bench-view.sh   # and an older build's vol-view
#   REPEAT=3 VOLUMES="shapes512" scripts/bench-view.sh
#
# Installs chromium and mricron-data (apt-get) and playwright (pip) when
# missing. Outputs under DIR (default out/bench-view).
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${REPEAT:-5}
DIR=${DIR:-out/bench-view}
VOLUMES=${VOLUMES:-shapes512 brain}
mkdir -p "$DIR"
need_apt() {
    command -v apt-get >/dev/null 2>&1 || { echo "bench-view: no apt-get to install $1" >&2; exit 1; }
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$1" >/dev/null
}
command -v chromium >/dev/null 2>&1 || need_apt chromium
[ -f /usr/share/mricron/templates/ch2.nii.gz ] || need_apt mricron-data
python3 -c 'import playwright.sync_api' 2>/dev/null ||
    python3 -m pip install -q playwright 2>/dev/null ||
    python3 -m pip install -q --break-system-packages playwright
cargo build --release --quiet -p volview --bin vol-view
cargo build --release --quiet --bin vol-gen
B=${CARGO_TARGET_DIR:-target}/release
bins=(--bin "new=$B")
[ -n "${BASE:-}" ] && bins+=(--bin "base=$BASE")
for v in $VOLUMES; do
    case $v in
    shapes512)
        # Dense: 600 objects of 140 voxels fill most of the volume, seen
        # through the translucent grey ramp (no ray ends early).
        [ -f "$DIR/shapes512.vvol" ] ||
            "$B/vol-gen" shapes --dims 512,512,512 --count 600 --size 140 \
                -o "$DIR/shapes512.vvol" --quiet
        printf 'volume = "shapes512.vvol"\ntf = "grey"\nshading = "phong"\nsize = [512, 512]\n' \
            >"$DIR/shapes512.toml" ;;
    brain)
        cp /usr/share/mricron/templates/ch2.nii.gz "$DIR/ch2.nii.gz"
        printf 'volume = "ch2.nii.gz"\ntf = "auto"\nshading = "phong"\nup = "patient"\nsize = [512, 512]\n' \
            >"$DIR/brain.toml" ;;
    *) echo "bench-view: unknown volume $v (shapes512, brain)" >&2; exit 2 ;;
    esac
    echo "bench-view: $v ($REPEAT rounds)" >&2
    python3 view/tests/browser/bench_view.py --chromium "$(command -v chromium)" \
        --scene "$DIR/$v.toml" "${bins[@]}" --repeat "$REPEAT" | tee "$DIR/$v.json"
done
