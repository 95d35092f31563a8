#!/usr/bin/env bash
# Work-precision and drift figures of pgi against GSL's and Boost.Odeint's integrators (issues 5 and 33), for the rigid
# body, the cyclic Lotka-Volterra system and Henon-Heiles:  bash tools/peers/run.sh [OUTDIR] [DRIFT_T_END] [LONG_T_END]
# Installs GSL, Boost and gnuplot (Debian), builds pgi_peers in $BUILD (default build), writes OUTDIR/*.csv, *.json and
# *.svg, the stiff and extreme suite's table (OUTDIR/suite.md), with LONG_T_END the long-run tables (pgi_peers --long),
# and every scene's JSON together in tools/peers/peers_results.json. The peers run on their own right-hand side, C
# compiled by the system C compiler ($CC, else cc) when pgi_peers starts; pgi in its default configuration, with an
# empty JIT cache of the run's own (a first run's native code policy: machine code until native code pays).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-docs/figures}
drift_t=${2:-10000}
long_t=${3:-0}
build=${BUILD:-build}
bash tools/deps.sh libgsl-dev libboost-dev gnuplot-nox
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$(nproc)" --target pgi_peers
build=$(cd "$build" && pwd)
PGI_JIT_CACHE=$(mktemp -d)
export PGI_JIT_CACHE
trap 'rm -rf "$PGI_JIT_CACHE"' EXIT
mkdir -p "$out"
for scene in rigid_body lotka_volterra henon_heiles; do
    long=()
    [ "$long_t" = 0 ] || long=(--long "$long_t")
    "$build/pgi_peers" "tools/scenes/$scene.toml" --csv "$out/$scene-work-precision.csv" --plot "$out/$scene-work-precision.svg" \
        --drift "$out/$scene-drift.csv" --drift-t-end "$drift_t" "${long[@]}" > "$out/$scene-peers.json"
    gnuplot -e "kind='drift'; csv='$out/$scene-drift.csv'; out='$out/$scene-drift.svg'; name='$scene'" tools/peers/plot.gp
done
python3 tools/peers/suite.py --build "$build" --json "$out/suite.json" --md "$out/suite.md"
python3 - "$out" tools/peers/peers_results.json <<'PY'
import json, os, sys, time
out, target = sys.argv[1], sys.argv[2]
results = {"written_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()), "load_average": os.getloadavg()}
for scene in ("rigid_body", "lotka_volterra", "henon_heiles"):
    with open(os.path.join(out, scene + "-peers.json")) as f:
        results[scene] = json.load(f)
with open(os.path.join(out, "suite.json")) as f:
    results["suite"] = json.load(f)
with open(target + ".tmp", "w") as f:
    json.dump(results, f, indent=1)
os.replace(target + ".tmp", target)
PY
echo "figures in $out; results in tools/peers/peers_results.json"
