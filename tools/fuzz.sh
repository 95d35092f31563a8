#!/usr/bin/env bash
# Fuzzes the whole pipeline (scene reader, checks, S_1..S_k, modified Hamiltonian, Magnus series, a few
# steps; tests/fuzz/pipeline.hpp), the polynomial reader and the ensemble states reader (NPY, CSV) with
# libFuzzer for N seconds (default 600):
#   bash tools/fuzz.sh [SECONDS]
# Builds build-fuzz/ with clang (-fsanitize=fuzzer,address,undefined), seeds the corpus with the bundled
# scenes, the bad scenes and the regression seeds, and leaves new inputs in build-fuzz/corpus and crashes
# in build-fuzz/crashes/ (copy each into tests/fuzz/regressions/ once fixed). Exits non-zero on a finding.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
bash tools/deps.sh
command -v clang++ >/dev/null || bash tools/deps.sh clang libclang-rt-14-dev
source tools/cmake_configure.sh
pgi_configure build-fuzz -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPGI_FUZZ=ON
cmake --build build-fuzz --target pgi_fuzz_pipeline -j "$(nproc)"
mkdir -p build-fuzz/corpus build-fuzz/crashes
cp tools/scenes/*.toml tests/bad_scenes/*.toml tests/fuzz/regressions/* build-fuzz/corpus/
cd build-fuzz
# -timeout and -rss_limit_mb sit well above the pipeline's own budget (1 s for each of its six exact calls, 1 GB of
# exact phase), so a report means pgi failed to bound itself
UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 ./pgi_fuzz_pipeline -max_total_time="$seconds" -timeout=30 \
    -rss_limit_mb=3072 -max_len=4096 -dict=../tests/fuzz/scene.dict -artifact_prefix=crashes/ -print_final_stats=1 corpus
