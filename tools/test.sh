#!/usr/bin/env bash
# Second command of the README: install, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/build.sh
ctest --test-dir build --output-on-failure
