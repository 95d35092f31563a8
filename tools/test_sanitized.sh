#!/usr/bin/env bash
# The test suite again under AddressSanitizer and UndefinedBehaviorSanitizer (build-asan/), then valgrind's
# memcheck on small scenes with the Release build (build/). Self-sufficient from a fresh clone: installs
# what it needs (the tests' extras and valgrind) and builds both trees. Run by CI after tools/test.sh.
#   bash tools/test_sanitized.sh        (PGI_JOBS=N to change the build parallelism, default nproc)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${PGI_JOBS:-$(nproc)}
bash tools/deps.sh texlive-latex-base libgsl-dev libboost-dev python3 valgrind
source tools/cmake_configure.sh
pgi_configure build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPGI_SANITIZE=ON
# every target a registered test runs (pgi_dmv_test exists when GSL and Boost are installed, as deps.sh ensures)
cmake --build build-asan -j "$jobs" --target pgi pgi_tests pgi_dmv_test
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    ctest --test-dir build-asan --output-on-failure -j "$jobs"
# memcheck on the Release build (valgrind cannot run ASan binaries): every FLINT object is freed (no leak
# from the wrappers). pgi links mimalloc (CMakeLists.txt, PGI_MIMALLOC): valgrind puts its own malloc in place of
# mimalloc's too (the soname synonym), and mimalloc's aliases for new, new[] and malloc would read as mismatched
# frees, so those are not reported; leaks and invalid accesses still are.
memcheck=(valgrind "--soname-synonyms=somalloc=libmimalloc.so*" --show-mismatched-frees=no --error-exitcode=1 --leak-check=full
          --errors-for-leak-kinds=definite,indirect,possible --quiet)
pgi_configure build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$jobs" --target pgi
"${memcheck[@]}" ./build/pgi run tools/scenes/harmonic_oscillator.toml --t-end 1 >/dev/null
"${memcheck[@]}" ./build/pgi report tools/scenes/rigid_body.toml --t-end 1 --format json >/dev/null
echo "sanitized tests and memcheck: clean"
