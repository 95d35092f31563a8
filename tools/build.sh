#!/usr/bin/env bash
# Configures and builds pgi (Release) in build/ after installing what is missing, then installs it into
# /usr/local: headers include/pgi/, libpgi.a, the CMake package (find_package(pgi)), the pgi program and
# the Python package pgi (into the /usr/local directory on /usr/bin/python3's sys.path).
# Usage: bash tools/build.sh [--all]. Without --all only what is installed is built (the library, pgi and the
# Python module: the set-up's few minutes); with --all every target too (tests, benchmarks, peers: tools/test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
targets=(--target pgi_core pgi pgi_python)
[ "${1:-}" = "--all" ] && targets=()
bash tools/deps.sh
source tools/cmake_configure.sh
pgi_configure build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)" "${targets[@]}"
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
"${sudo_cmd[@]}" cmake --install build >/dev/null
