#!/usr/bin/env bash
# Benchmark: what building volkit costs, the budget the lean-builds issue
# (41) set. A clean release build of the workspace in a target directory
# of its own (the usual target/ is left alone), timed as a whole and per
# crate (cargo's --timings), then one edit to the renderer's hot loop and
# the rebuild of vol-render, and every tool's machine code (`size`).
# Targets (2 cores): clean build <= 8 min, the workspace's own crates
# <= 2.5 min of it, volrender <= 60 s; the rebuild after touching
# render/src/integrator/dvr/mod.rs <= 2 min; vol-render's text <= 12 MB,
# every tool's <= 15 MB.
# Usage: scripts/bench-build.sh            (target dir out/bench-build)
#        DIR=/tmp/b scripts/bench-build.sh
#        FEATURES=mpi scripts/bench-build.sh   (the tools with a feature)
set -euo pipefail
cd "$(dirname "$0")/.."
DIR=${DIR:-out/bench-build}
export CARGO_TARGET_DIR=$DIR/target
export CARGO_INCREMENTAL=0
rm -rf "$CARGO_TARGET_DIR"
mkdir -p "$DIR"
FEAT=()
[ -z "${FEATURES:-}" ] || FEAT=(--features "$FEATURES")

echo "clean release build, $(nproc) cores, load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
start=$(date +%s.%N)
cargo build --release --workspace --timings "${FEAT[@]}" > "$DIR/build.log" 2>&1 ||
    { tail -20 "$DIR/build.log"; exit 1; }
end=$(date +%s.%N)
awk -v a="$start" -v b="$end" 'BEGIN {printf "  wall: %.1f s (%.2f min)\n", b - a, (b - a) / 60}'

# Per unit from the timings page: the workspace's crates and the slowest
# third-party ones.
html=$(ls -t "$CARGO_TARGET_DIR"/cargo-timings/cargo-timing-*.html | head -1)
python3 - "$html" <<'EOF'
import json, re, sys
text = open(sys.argv[1]).read()
m = re.search(r'const UNIT_DATA = (\[.*?\]);\n', text, re.S)
units = json.loads(m.group(1))
ours = {"volkit", "volcore", "volformats", "volindex", "volrender", "volscene", "volcompare", "volkit-fuzz"}
by_name = {}
for u in units:
    key = (u["name"], u.get("target", ""))
    by_name[key] = by_name.get(key, 0) + u["duration"]
own = sorted(((d, n, t) for (n, t), d in by_name.items() if n in ours), reverse=True)
rest = sorted(((d, n, t) for (n, t), d in by_name.items() if n not in ours), reverse=True)
print(f"  workspace crates: {sum(d for d, _, _ in own):.1f} s of compile time in all (units overlap on 2 cores)")
for d, n, t in own:
    print(f"    {n}{t}: {d:.1f} s")
print(f"  third-party crates ({len({n for _, n, _ in rest})}): {sum(d for d, _, _ in rest):.1f} s in all; the slowest:")
for d, n, t in rest[:8]:
    print(f"    {n}{t}: {d:.1f} s")
EOF

# One edit to the hot loop, then what a renderer author waits for.
touch render/src/integrator/dvr/mod.rs
start=$(date +%s.%N)
cargo build --release --bin vol-render "${FEAT[@]}" > "$DIR/rebuild.log" 2>&1
end=$(date +%s.%N)
awk -v a="$start" -v b="$end" 'BEGIN {printf "  rebuild of vol-render after touching integrator/dvr/mod.rs: %.1f s\n", b - a}'

echo "machine code (text of size, MB):"
for b in "$CARGO_TARGET_DIR"/release/vol-*; do
    case $b in *.d) continue ;; esac
    size "$b" | awk -v n="$(basename "$b")" 'NR == 2 {printf "  %-14s %6.2f\n", n, $1 / 1e6}'
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
