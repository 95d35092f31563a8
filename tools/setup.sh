#!/usr/bin/env bash
# First command of the README: install the Debian packages, build and install the library, the program pgi and the
# Python module (not the tests: tools/test.sh builds them), and run the main job on the default scene.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/build.sh
./build/pgi run tools/scenes/rigid_body.toml
