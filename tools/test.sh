#!/usr/bin/env bash
# Second command of the README: install, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/build.sh
# the report tests compile pgi's LaTeX with pdflatex: a test-only dependency
if ! command -v pdflatex >/dev/null 2>&1; then
    sudo_cmd=()
    [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
    echo "pgi: installing texlive-latex-base for the report tests" >&2
    DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq texlive-latex-base >/dev/null
fi
ctest --test-dir build --output-on-failure
