// libFuzzer target: the scene reader and the polynomial parser on arbitrary bytes (tools/fuzz.sh runs it).
// Bad input must end in pgi's exceptions (SceneError, ParseError, std::invalid_argument): a crash, an
// abort inside FLINT, a sanitizer report or a hang is a finding.
#include "tools/scene.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    try {
        pgi::Scene s = pgi::parse_scene(text, "fuzz.toml");
        pgi::require_valid(s);
    } catch (const std::invalid_argument&) {
    } catch (const std::runtime_error&) {
    }
    // the polynomial parser alone, in a small ring
    try {
        static const auto ring = pgi::make_ring({"x", "y", "z"});
        (void)pgi::Poly::parse(ring, text);
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
