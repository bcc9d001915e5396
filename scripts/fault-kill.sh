#!/usr/bin/env bash
# Fault tests in full (issue 43): every writer (.vvol sliced, bricked and
# zstd, .vpart merge, NIfTI .nii and .hdr/.img, NRRD .nrrd and .nhdr/.raw,
# MetaImage .mhd/.raw, OME-Zarr, TIFF file and slice folder, vol-render's
# PNG+PFM, .vidx, the --accumulate state) killed with SIGKILL at KILLS
# moments spread over its run (deterministic seeds), each checked for a
# complete previous or new output and no piled-up temporary files; every
# writer on a full tmpfs (as root); and REPLACEMENTS renames of a .vvol
# under 8 looping renders. CI (cargo test) runs 4 kills per writer and 12
# replacements. Each test prints one `faults:` line with its figures.
# Usage: scripts/fault-kill.sh [KILLS] [REPLACEMENTS]   (default 100 50)
#        THREADS=1 scripts/fault-kill.sh                 (tests one at a time)
set -euo pipefail
cd "$(dirname "$0")/.."
export VOLKIT_FAULT_KILLS=${1:-100}
export VOLKIT_FAULT_REPLACEMENTS=${2:-50}
start=$(date +%s)
log=$(mktemp)
trap 'rm -f "$log"' EXIT
set +e
cargo test --release -p volkit --test it hard_cases::faults:: -- \
    --nocapture --test-threads "${THREADS:-2}" >"$log" 2>&1
status=$?
set -e
grep -E '^faults:|^test |test result' "$log" || true
[ "$status" = 0 ] || { cat "$log"; }
echo "fault-kill.sh: $VOLKIT_FAULT_KILLS kills per writer, $VOLKIT_FAULT_REPLACEMENTS replacements, $(($(date +%s) - start)) s, exit $status"
exit "$status"
