#!/usr/bin/env bash
# Work-precision and drift figures of pgi against GSL's and Boost.Odeint's integrators (issue 5), for the rigid body, the cyclic
# Lotka-Volterra system and Henon-Heiles:  bash tools/peers/run.sh [OUTDIR] [DRIFT_T_END]
# Installs GSL, Boost and gnuplot (Debian), builds pgi_peers, writes OUTDIR/*.csv, *.json and *.svg.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-docs/figures}
drift_t=${2:-10000}
bash tools/deps.sh
missing=()
for p in libgsl-dev libboost-dev gnuplot-nox; do dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p"); done
if ((${#missing[@]})); then
    sudo_cmd=(); [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
    DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" --target pgi_peers
mkdir -p "$out"
for scene in rigid_body lotka_volterra henon_heiles; do
    ./build/pgi_peers "tools/scenes/$scene.toml" --csv "$out/$scene-work-precision.csv" --drift "$out/$scene-drift.csv" \
        --drift-t-end "$drift_t" > "$out/$scene-peers.json"
    gnuplot -e "scene='$scene'; dir='$out'" tools/peers/plot.gp
done
echo "figures in $out"
