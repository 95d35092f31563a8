#!/usr/bin/env bash
# First command of the README: install, build, and run the main job on the default scene.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/build.sh
./build/pgi run tools/scenes/rigid_body.toml
