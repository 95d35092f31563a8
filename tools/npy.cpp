#include "tools/npy.hpp"

#include "scheme/input.hpp"
#include "scheme/detail/input_file.hpp"

#include <bit>
#include <charconv>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace pgi {

static_assert(std::endian::native == std::endian::little, "NPY '<f8' is read and written as the host's doubles");

namespace {

// At most the first 40 characters of a field, for a message (a 50 MB field is not echoed whole).
std::string excerpt(const std::string& field) {
    constexpr std::size_t shown = 40;
    return field.size() <= shown ? field
                                 : field.substr(0, shown) + "... (" + std::to_string(field.size()) + " characters)";
}

// The header's dict literal: {'key': value, ...} with string, True/False and tuple-of-integers values.
class HeaderParser {
public:
    HeaderParser(std::string_view text, std::string file) : s_(text), file_(std::move(file)) {}

    std::map<std::string, std::string> parse() {
        std::map<std::string, std::string> d;
        expect('{');
        while (true) {
            skip();
            if (peek() == '}') break;
            std::string key = string_literal();
            expect(':');
            skip();
            if (d.count(key)) fail("key '" + key + "' appears twice");
            d[key] = value();
            skip();
            if (peek() == ',')
                ++i_;
            else if (peek() != '}')
                fail("expected ',' or '}' at byte " + std::to_string(i_));
        }
        ++i_;
        while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\n')) ++i_;
        if (i_ != s_.size()) fail("text after the header's dict");
        return d;
    }

private:
    [[noreturn]] void fail(const std::string& why) const {
        throw InputError(file_, "not an NPY file pgi reads: header: " + why);
    }
    char peek() const { return i_ < s_.size() ? s_[i_] : '\0'; }
    void skip() {
        while (peek() == ' ') ++i_;
    }
    void expect(char c) {
        skip();
        if (peek() != c) fail(std::string("expected '") + c + "' at byte " + std::to_string(i_));
        ++i_;
    }
    std::string string_literal() {
        const char q = peek();
        if (q != '\'' && q != '"') fail("expected a quoted key or string at byte " + std::to_string(i_));
        const auto end = s_.find(q, i_ + 1);
        if (end == std::string_view::npos) fail("unterminated string");
        std::string out(s_.substr(i_ + 1, end - i_ - 1));
        i_ = end + 1;
        return "'" + out + "'";
    }
    // a value as canonical text: 'string', True, False or (m, n)
    std::string value() {
        if (peek() == '\'' || peek() == '"') return string_literal();
        if (s_.substr(i_, 4) == "True") return i_ += 4, "True";
        if (s_.substr(i_, 5) == "False") return i_ += 5, "False";
        if (peek() != '(') fail("unexpected value at byte " + std::to_string(i_));
        ++i_;
        std::string out = "(";
        for (bool first = true;; first = false) {
            skip();
            if (peek() == ')') break;
            std::size_t v = 0;
            const auto [p, ec] = std::from_chars(s_.data() + i_, s_.data() + s_.size(), v);
            if (ec != std::errc()) fail("a shape holds a non-integer at byte " + std::to_string(i_));
            i_ = std::size_t(p - s_.data());
            out += (first ? "" : ",") + std::to_string(v);
            skip();
            if (peek() == ',')
                ++i_;
            else if (peek() != ')')
                fail("expected ',' or ')' in the shape");
        }
        ++i_;
        return out + ")";
    }

    std::string_view s_;
    std::string file_;
    std::size_t i_ = 0;
};

std::pair<std::size_t, std::size_t> shape_of(const std::string& t, const std::string& file) {
    std::size_t m = 0, n = 0;
    const auto comma = t.find(',');
    if (comma == std::string::npos || t.find(',', comma + 1) != std::string::npos)
        throw InputError(file,
                         "shape " + t + " is not 2-D: the initial states are an (m, n) array, one row per trajectory");
    std::from_chars(t.data() + 1, t.data() + comma, m);
    std::from_chars(t.data() + comma + 1, t.data() + t.size() - 1, n);
    return {m, n};
}

}  // namespace

RowMatrix read_npy(const std::filesystem::path& path, std::size_t max_bytes) {
    return parse_npy(read_input_file(path, max_bytes, "states"), path.string());
}

RowMatrix parse_npy(const std::string& bytes, const std::string& file) {
    const std::size_t size = bytes.size();
    std::istringstream in(bytes);
    char magic[8] = {};
    in.read(magic, 8);
    if (!in || std::string_view(magic, 6) != "\x93NUMPY")
        throw InputError(file, "not an NPY file (no \\x93NUMPY magic)");
    const int major = static_cast<unsigned char>(magic[6]);
    if (major < 1 || major > 3 || magic[7] != 0)
        throw InputError(file, "NPY version " + std::to_string(major) + "." + std::to_string(int(magic[7])) +
                                   " is not 1.0, 2.0 or 3.0");
    unsigned char len_bytes[4] = {};
    const std::size_t len_size = major == 1 ? 2 : 4;
    in.read(reinterpret_cast<char*>(len_bytes), std::streamsize(len_size));
    std::size_t header_len = 0;
    for (std::size_t b = 0; b < len_size; ++b) header_len |= std::size_t(len_bytes[b]) << (8 * b);
    const std::size_t offset = 8 + len_size + header_len;
    if (!in || header_len > 65536 || offset > size)
        throw InputError(file, "NPY header length " + std::to_string(header_len) + " does not fit the file");
    std::string header(header_len, '\0');
    in.read(header.data(), std::streamsize(header_len));
    auto d = HeaderParser(header, file).parse();
    if (d.size() != 3 || !d.count("'descr'") || !d.count("'fortran_order'") || !d.count("'shape'"))
        throw InputError(file, "NPY header must hold exactly descr, fortran_order and shape");
    if (d["'descr'"] != "'<f8'")
        throw InputError(file, "dtype " + d["'descr'"] + " is not float64 ('<f8'): save X0.astype('<f8')");
    if (d["'fortran_order'"] != "False")
        throw InputError(file, "a Fortran-ordered array: save np.ascontiguousarray(X0)");
    const auto [m, n] = shape_of(d["'shape'"], file);
    const std::size_t data = size - offset;
    if (n == 0 || m > data / 8 / n || data != m * n * 8)
        throw InputError(file, "shape (" + std::to_string(m) + ", " + std::to_string(n) + ") needs " +
                                   (n ? std::to_string(m) + " x " + std::to_string(n) + " x 8" : "0") +
                                   " bytes of data, the file has " + std::to_string(data));
    RowMatrix a{Eigen::Index(m), Eigen::Index(n)};
    in.read(reinterpret_cast<char*>(a.data()), std::streamsize(data));
    if (!in) throw InputError(file, "cannot read the data");
    return a;
}

void write_npy(std::ostream& out, const Eigen::Ref<const RowMatrix>& a) {
    std::string header = "{'descr': '<f8', 'fortran_order': False, 'shape': (" + std::to_string(a.rows()) + ", " +
                         std::to_string(a.cols()) + "), }";
    const std::size_t total = (10 + header.size() + 1 + 63) / 64 * 64;
    header.append(total - 10 - header.size() - 1, ' ');
    header += '\n';
    const std::uint16_t len = std::uint16_t(header.size());
    out.write("\x93NUMPY\x01\x00", 8);
    const char len_bytes[2] = {char(len & 0xff), char(len >> 8)};
    out.write(len_bytes, 2);
    out << header;
    for (Eigen::Index i = 0; i < a.rows(); ++i)
        out.write(reinterpret_cast<const char*>(a.row(i).data()),
                  std::streamsize(sizeof(double) * std::size_t(a.cols())));
}

RowMatrix read_csv_states(const std::filesystem::path& path, std::size_t columns, const std::string& header,
                          std::size_t max_bytes) {
    return parse_csv_states(read_input_file(path, max_bytes, "states"), path.string(), columns, header);
}

RowMatrix parse_csv_states(const std::string& text, const std::string& file, std::size_t columns,
                           const std::string& header) {
    std::istringstream in(text);
    std::vector<double> values;
    std::string line;
    bool first = true;
    for (std::size_t number = 1; std::getline(in, line); ++number) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.find_first_not_of(" \t") == std::string::npos || line[0] == '#') continue;
        if (std::exchange(first, false) && line == header) continue;
        std::size_t count = 0, start = 0;
        while (true) {
            const auto end = std::min(line.find(',', start), line.size());
            std::string field = line.substr(start, end - start);
            const auto a = field.find_first_not_of(" \t"), b = field.find_last_not_of(" \t");
            field = a == std::string::npos ? "" : field.substr(a, b - a + 1);
            double v = 0;
            const auto [p, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
            if (field.empty() || ec != std::errc() || p != field.data() + field.size())
                throw InputError(file + ":" + std::to_string(number),
                                 "field " + std::to_string(count + 1) + " '" + excerpt(field) + "' is not a number");
            values.push_back(v);
            ++count;
            if (end == line.size()) break;
            start = end + 1;
        }
        if (count != columns)
            throw InputError(file + ":" + std::to_string(number), "expected " + std::to_string(columns) + " values (" +
                                                                      header + "), got " + std::to_string(count));
    }
    return Eigen::Map<const RowMatrix>(values.data(), Eigen::Index(values.size() / columns), Eigen::Index(columns));
}

}  // namespace pgi
