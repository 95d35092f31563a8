#!/usr/bin/env bash
# Second command of the README: install, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
# test-only dependencies: pdflatex compiles pgi's LaTeX reports, gnuplot draws a run's figures; GSL and Boost build pgi_peers, whose
# stiff and extreme suite is checked against the README's claims (python3 drives it)
bash tools/deps.sh texlive-latex-base gnuplot-nox libgsl-dev libboost-dev python3
bash tools/build.sh
ctest --test-dir build --output-on-failure
