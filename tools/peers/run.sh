#!/usr/bin/env bash
# Work-precision and drift figures of pgi against GSL's and Boost.Odeint's integrators (issue 5), for the rigid body, the cyclic
# Lotka-Volterra system and Henon-Heiles:  bash tools/peers/run.sh [OUTDIR] [DRIFT_T_END]
# Installs GSL, Boost and gnuplot (Debian), builds pgi_peers, writes OUTDIR/*.csv, *.json and *.svg, and the
# stiff and extreme suite's table (OUTDIR/suite.md).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-docs/figures}
drift_t=${2:-10000}
bash tools/deps.sh libgsl-dev libboost-dev gnuplot-nox
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$(nproc)" --target pgi_peers
mkdir -p "$out"
for scene in rigid_body lotka_volterra henon_heiles; do
    ./build/pgi_peers "tools/scenes/$scene.toml" --csv "$out/$scene-work-precision.csv" --plot "$out/$scene-work-precision.svg" \
        --drift "$out/$scene-drift.csv" --drift-t-end "$drift_t" > "$out/$scene-peers.json"
    gnuplot -e "kind='drift'; csv='$out/$scene-drift.csv'; out='$out/$scene-drift.svg'; name='$scene'" tools/peers/plot.gp
done
python3 tools/peers/suite.py --json "$out/suite.json" --md "$out/suite.md"
echo "figures in $out"
