#!/usr/bin/env bash
# Fuzzes the scene reader and the polynomial parser with libFuzzer for N seconds (default 600):
#   bash tools/fuzz.sh [SECONDS]
# Builds build-fuzz/ with clang (-fsanitize=fuzzer,address,undefined), seeds the corpus with the bundled and the
# bad scenes, and leaves new inputs in build-fuzz/corpus and crashes in build-fuzz/crash-*.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
bash tools/deps.sh
command -v clang++ >/dev/null || { sudo_cmd=(); [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo); "${sudo_cmd[@]}" apt-get install -y -qq clang libclang-rt-14-dev >/dev/null; }
cmake -S . -B build-fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPGI_FUZZ=ON >/dev/null
cmake --build build-fuzz --target pgi_fuzz_scene -j "$(nproc)"
mkdir -p build-fuzz/corpus
cp tools/scenes/*.toml tests/bad_scenes/*.toml build-fuzz/corpus/
cd build-fuzz
UBSAN_OPTIONS=halt_on_error=1 ./pgi_fuzz_scene -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -max_len=4096 \
    -print_final_stats=1 corpus
