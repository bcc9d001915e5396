#!/usr/bin/env bash
# Write every tool's shell completions and man page where shells and man
# look for them (per user by default; PREFIX=/usr/local for everyone).
# The tools must be on PATH (cargo install --path .) or in target/release.
set -euo pipefail
PREFIX=${1:-$HOME/.local}
if [ "$PREFIX" = "$HOME/.local" ]; then FISH=$HOME/.config/fish/completions; else FISH=$PREFIX/share/fish/vendor_completions.d; fi
mkdir -p "$PREFIX/share/bash-completion/completions" "$PREFIX/share/zsh/site-functions" "$FISH" "$PREFIX/share/man/man1"
for t in vol-gen vol-info vol-convert vol-index vol-psnr vol-render vol-accuracy; do
    bin=$(command -v "$t" || echo "$(dirname "$0")/../target/release/$t")
    "$bin" --completions bash > "$PREFIX/share/bash-completion/completions/$t"
    "$bin" --completions zsh > "$PREFIX/share/zsh/site-functions/_$t"
    "$bin" --completions fish > "$FISH/$t.fish"
    "$bin" --man > "$PREFIX/share/man/man1/$t.1"
done
echo "completions and man pages written under $PREFIX (and $FISH)"
