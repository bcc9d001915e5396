#!/usr/bin/env bash
# The whole test suite: every crate's tests, then the data-parallel
# renderer's tests under mpirun (cargo feature `mpi`) when Open MPI is
# installed. Without it those are skipped with a note; with
# VOLKIT_REQUIRE_MPI=1 (CI) a missing MPI is an error instead.
# The suite runs against release-profile artifacts: the tools it tests
# are the ones scripts/demo.sh then runs (built once, not once per
# profile), and the rendering tests run at full speed.
#
#   bash scripts/test.sh            # all tests
#   VOLKIT_REQUIRE_MPI=1 bash scripts/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."

cargo test --workspace --release

have_mpi() {
    command -v mpirun >/dev/null 2>&1 &&
        command -v pkg-config >/dev/null 2>&1 &&
        pkg-config --exists ompi 2>/dev/null
}

# The MPI tests are the module `mpi` of the end-to-end test binary `it`,
# compiled only with the feature; the filter runs just them (the rest of
# that binary already ran above).
if have_mpi; then
    # Only the root package is built again (with the feature).
    echo "== MPI: cargo test --release -p volkit --features mpi --test it mpi::"
    cargo test --release -p volkit --features mpi --test it mpi::
elif [ "${VOLKIT_REQUIRE_MPI:-0}" = 1 ]; then
    echo "test.sh: Open MPI not found (mpirun, pkg-config ompi); install libopenmpi-dev openmpi-bin libclang-dev pkg-config" >&2
    exit 1
else
    echo "test.sh: skipped the MPI tests: Open MPI not installed (Debian: apt-get install libopenmpi-dev openmpi-bin libclang-dev pkg-config)" >&2
fi
