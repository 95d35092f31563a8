#!/usr/bin/env bash
# Configures and builds pgi (Release) in build/ after installing what is missing, then installs it into
# /usr/local: headers include/pgi/, libpgi.a, the CMake package (find_package(pgi)), the pgi program and
# the Python package pgi (into the /usr/local directory on /usr/bin/python3's sys.path).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)"
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
"${sudo_cmd[@]}" cmake --install build >/dev/null
