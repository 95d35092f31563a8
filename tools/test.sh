#!/usr/bin/env bash
# Second command of the README: install, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
# test-only dependencies: pdflatex compiles pgi's LaTeX reports, gnuplot draws a run's figures; GSL and Boost build pgi_peers, whose
# stiff and extreme suite is checked against the documented claims (python3 drives it); mypy's stubtest checks the
# Python package's type stubs against the module
bash tools/deps.sh texlive-latex-base gnuplot-nox libgsl-dev libboost-dev python3 python3-mypy python3-hypothesis
bash tools/build.sh --all
ctest --test-dir build --output-on-failure -j "$(nproc)"
