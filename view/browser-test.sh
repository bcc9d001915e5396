#!/usr/bin/env bash
# vol-view's browser tests: Playwright for Python driving the system's
# Chromium (Playwright cannot download its own browsers here). Installs
# chromium (apt-get) and playwright (pip) when missing; skips, saying so,
# only where no browser can be installed. Builds vol-view, vol-gen and
# vol-render (release) first.
#
#   view/browser-test.sh                      # the test
#   VIEW_SCREENSHOT=docs/view.png view/browser-test.sh   # and the README's screenshot
#   VIEW_TIMING=report view/browser-test.sh   # report the latencies, do not assert them
set -euo pipefail
cd "$(dirname "$0")/.."

skip() {
    echo "browser-test: SKIPPED: $*" >&2
    exit 0
}

chromium_path() {
    command -v chromium || command -v chromium-browser || true
}

if [ -z "$(chromium_path)" ]; then
    if command -v apt-get >/dev/null 2>&1; then
        echo "browser-test: installing chromium (apt-get)" >&2
        (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium) >/dev/null 2>&1 || true
    fi
fi
CHROMIUM=${CHROMIUM:-$(chromium_path)}
[ -n "$CHROMIUM" ] || skip "no Chromium, and apt-get could not install one"
command -v python3 >/dev/null 2>&1 || skip "no python3 for Playwright"
if ! python3 -c 'import playwright.sync_api' >/dev/null 2>&1; then
    echo "browser-test: installing playwright (pip)" >&2
    python3 -m pip install -q playwright >/dev/null 2>&1 ||
        python3 -m pip install -q --break-system-packages playwright >/dev/null 2>&1 || true
fi
python3 -c 'import playwright.sync_api' >/dev/null 2>&1 || skip "pip could not install playwright"

export CARGO_INCREMENTAL=${CARGO_INCREMENTAL:-0}
cargo build --release --quiet -p volview --bin vol-view
cargo build --release --quiet --bin vol-gen --bin vol-render
B=${CARGO_TARGET_DIR:-target}/release

args=(--bin "$B" --chromium "$CHROMIUM")
[ -n "${VIEW_SCREENSHOT:-}" ] && args+=(--screenshot "$VIEW_SCREENSHOT")
[ "${VIEW_TIMING:-assert}" = report ] && args+=(--no-timing-asserts)
python3 view/tests/browser/test_view.py "${args[@]}"
