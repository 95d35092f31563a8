#include "series/message.hpp"

#include <vector>

namespace pgi {

std::string printable(std::string_view s) {
    std::string out;
    out.reserve(s.size());
    for (char c : s) {
        const auto u = static_cast<unsigned char>(c);
        if (u < 0x20 || u == 0x7f) {
            const char* hex = "0123456789abcdef";
            out += "\\x";
            out += hex[u >> 4];
            out += hex[u & 15];
        } else {
            out += c;
        }
    }
    return out;
}

std::string output_tail(std::string_view output, std::size_t lines, std::size_t max_chars) {
    std::vector<std::string_view> kept;  // from the last line backwards
    for (std::size_t end = output.size(); end > 0 && kept.size() < lines;) {
        const std::size_t newline = output.rfind('\n', end - 1);
        const std::size_t start = newline == std::string_view::npos ? 0 : newline + 1;
        std::string_view line = output.substr(start, end - start);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (!line.empty()) kept.push_back(line);
        if (newline == std::string_view::npos) break;
        end = newline;
    }
    std::string joined;
    for (auto it = kept.rbegin(); it != kept.rend(); ++it) joined += (joined.empty() ? "" : " | ") + printable(*it);
    if (joined.size() > max_chars) joined = "..." + joined.substr(joined.size() - max_chars + 3);
    return joined;
}

}  // namespace pgi
