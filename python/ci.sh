#!/usr/bin/env bash
# CI step for the Python package (issue 44): build and install it with pip
# in a fresh virtual environment (maturin as the PEP 517 backend, sharing
# the workspace's target directory so the crates compiled for the tools
# are reused), then run its pytest suite against the workspace's binaries.
# Usage: python/ci.sh   (from anywhere; VENV=dir to keep the environment)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
cd "$root"
export CARGO_INCREMENTAL=0
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target}
venv=${VENV:-$(mktemp -d)/venv}

echo "== python: fresh venv at $venv"
if ! python3 -m venv "$venv" >/dev/null 2>&1; then
    # Debian's python3 keeps ensurepip in python3-venv.
    if command -v apt-get >/dev/null 2>&1; then
        (apt-get update -qq && apt-get install -y -qq python3-venv) >/dev/null 2>&1 || true
    fi
    rm -rf "$venv"
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --upgrade pip
# The workspace's binaries, which the tests compare against.
if [ ! -x "$CARGO_TARGET_DIR/release/vol-render" ] || [ ! -x "$CARGO_TARGET_DIR/release/vol-convert" ]; then
    echo "== python: cargo build --release (the tools the tests compare with)"
    cargo build --release --quiet --bins
fi
echo "== python: pip install ./python"
start=$(date +%s)
"$venv/bin/python" -m pip install -q ./python
echo "python: installed in $(($(date +%s) - start)) s"
# nibabel: the reference the affine is checked against; mypy: the stubs
# are checked against a typed example (examples/tour.py).
"$venv/bin/python" -m pip install -q pytest numpy nibabel mypy
echo "== python: pytest"
# From the tests' folder: run from python/, `python -m pytest` would import
# the source folder volkit/ (without its compiled module) instead of the
# installed package.
cd "$here/tests"
VOLKIT_BIN_DIR="$CARGO_TARGET_DIR/release" "$venv/bin/python" -m pytest -q .
echo "== python: the typed example, run and type-checked with mypy"
"$venv/bin/python" "$here/examples/tour.py"
"$venv/bin/python" -m mypy --strict "$here/examples/tour.py"
