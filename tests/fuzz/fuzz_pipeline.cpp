// libFuzzer target: the whole pipeline (tests/fuzz/pipeline.hpp), the polynomial reader and the ensemble's
// states reader (NPY and CSV) on arbitrary bytes; tools/fuzz.sh runs it. A crash it finds goes to
// tests/fuzz/regressions/, replayed by the tests.
#include "tests/fuzz/pipeline.hpp"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    (void)pgi::fuzz::run_pipeline(text);
    (void)pgi::fuzz::run_parser(text);
    (void)pgi::fuzz::run_states(text);
    return 0;
}
