#!/usr/bin/env bash
# The test suite again under AddressSanitizer and UndefinedBehaviorSanitizer (build-asan/), then valgrind's
# memcheck on a small scene. Run by CI after tools/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/deps.sh
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPGI_SANITIZE=ON >/dev/null
cmake --build build-asan -j "$(nproc)" --target pgi pgi_tests
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    ctest --test-dir build-asan --output-on-failure
if ! command -v valgrind >/dev/null 2>&1; then
    sudo_cmd=(); [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
    DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq valgrind >/dev/null
fi
# memcheck on the Release build: every FLINT object is freed (no leak from the wrappers)
valgrind --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite,indirect,possible --quiet \
    ./build/pgi run tools/scenes/harmonic_oscillator.toml --t-end 1 >/dev/null
valgrind --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite,indirect,possible --quiet \
    ./build/pgi report tools/scenes/rigid_body.toml --t-end 1 --format json >/dev/null
echo "sanitized tests and memcheck: clean"
