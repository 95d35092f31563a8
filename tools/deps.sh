#!/usr/bin/env bash
# Installs the Debian packages pgi builds with, and any named as arguments (the tests' and the peers'
# extras), if any is missing. Idempotent; needs root or sudo.  Usage: bash tools/deps.sh [PACKAGE...]
set -euo pipefail
packages=(build-essential cmake ninja-build pkg-config libflint-dev libmpfr-dev libgmp-dev libeigen3-dev libtbb-dev doctest-dev
          libtomlplusplus-dev libcli11-dev nlohmann-json3-dev libfmt-dev libmimalloc-dev libxbyak-dev pybind11-dev python3-dev python3-numpy
          python3-pytest "$@")
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
    echo "pgi: installing ${missing[*]}" >&2
    sudo_cmd=()
    [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
    "${sudo_cmd[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi
