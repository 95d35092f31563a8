#include "tools/sample.hpp"

#include "scheme/input.hpp"

#include <charconv>
#include <cmath>
#include <random>
#include <sstream>

namespace pgi {

SampleKind parse_sample_kind(const std::string& text) {
    if (text == "grid") return SampleKind::grid;
    if (text == "box") return SampleKind::box;
    if (text == "casimir") return SampleKind::casimir;
    throw InputError("--sample", "'" + text + "' is not grid, box or casimir");
}

void parse_box(const std::string& text, std::size_t n, SampleSpec& spec) {
    std::vector<double> v;
    std::stringstream in(text);
    for (std::string field; std::getline(in, field, ',');) {
        double x = 0;
        const auto [p, ec] = std::from_chars(field.data(), field.data() + field.size(), x);
        if (field.empty() || ec != std::errc() || p != field.data() + field.size() || !std::isfinite(x))
            throw InputError("--box", "'" + field + "' is not a finite number");
        v.push_back(x);
    }
    if (v.size() != 2 && v.size() != 2 * n)
        throw InputError("--box", "give lo,hi or lo,hi for each of the " + std::to_string(n) + " coordinates, got " +
                                      std::to_string(v.size()) + " numbers");
    spec.lo.assign(n, 0);
    spec.hi.assign(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t j = v.size() == 2 ? 0 : 2 * i;
        spec.lo[i] = v[j], spec.hi[i] = v[j + 1];
        if (!(spec.lo[i] < spec.hi[i]))
            throw InputError("--box", "lo must be below hi (coordinate " + std::to_string(i + 1) + ")");
    }
}

namespace {

double uniform(std::mt19937_64& rng, double lo, double hi) {
    return lo + (hi - lo) * (double(rng() >> 11) * 0x1.0p-53);
}

RowMatrix grid(const SampleSpec& s, std::size_t n) {
    const auto g = std::size_t(std::llround(std::pow(double(s.count), 1.0 / double(n))));
    std::size_t total = 1;
    for (std::size_t i = 0; i < n; ++i) total *= g;
    if (total != s.count)
        throw InputError("--count", std::to_string(s.count) + " is not g^" + std::to_string(n) +
                                        " for a whole g (grid: g points per coordinate)");
    RowMatrix X(Eigen::Index(s.count), Eigen::Index(n));
    for (std::size_t r = 0; r < s.count; ++r)
        for (std::size_t c = n, rest = r; c-- > 0; rest /= g) {
            const double k = double(rest % g);
            X(Eigen::Index(r), Eigen::Index(c)) =
                g == 1 ? (s.lo[c] + s.hi[c]) / 2 : s.lo[c] + (s.hi[c] - s.lo[c]) * k / double(g - 1);
        }
    return X;
}

RowMatrix box(const SampleSpec& s, std::size_t n) {
    std::mt19937_64 rng(s.seed);
    RowMatrix X(Eigen::Index(s.count), Eigen::Index(n));
    for (Eigen::Index r = 0; r < X.rows(); ++r)
        for (std::size_t c = 0; c < n; ++c) X(r, Eigen::Index(c)) = uniform(rng, s.lo[c], s.hi[c]);
    return X;
}

// the degree d if every term of C has total degree d, else 0
long homogeneous_degree(const Poly& C) {
    const long d = C.total_degree();
    for (std::size_t t = 0; t < C.length(); ++t) {
        long sum = 0;
        for (auto e : C.term_exponents(t)) sum += long(e);
        if (sum != d) return 0;
    }
    return d;
}

RowMatrix casimir(const Scheme& scheme, const SampleSpec& s, std::size_t n) {
    if (scheme.casimirs().size() != 1)
        throw InputError("--sample casimir",
                         "needs exactly one Casimir in the scene, it has " + std::to_string(scheme.casimirs().size()));
    const Poly& C = scheme.casimirs()[0];
    const long d = homogeneous_degree(C);
    if (d < 1)
        throw InputError("--sample casimir",
                         "the Casimir " + C.to_string() + " is not homogeneous: no rescaling reaches its level sets");
    if (!s.through)
        throw InputError("--sample casimir", "needs the state the level set goes through: give --x0 or [run] x0");
    const CompiledMap inv = scheme.invariants();  // H, C
    std::vector<double> values(inv.num_outputs());
    const auto C_at = [&](const double* x) {
        inv.eval(x, values.data());
        return values[1];
    };
    const double c0 = C_at(s.through->data());
    if (!(c0 != 0) || !std::isfinite(c0))
        throw InputError("--sample casimir",
                         "C(x0) = " + std::to_string(c0) + ": the level set is not reached by rescaling");
    std::mt19937_64 rng(s.seed);
    RowMatrix X(Eigen::Index(s.count), Eigen::Index(n));
    Eigen::VectorXd y{Eigen::Index(n)};
    std::size_t filled = 0;
    for (std::size_t draws = 0; filled < s.count; ++draws) {
        if (draws >= 100 * s.count)
            throw InputError("--box", "too few points of the box have C of the sign of C(x0) = " + std::to_string(c0));
        for (std::size_t c = 0; c < n; ++c) y(Eigen::Index(c)) = uniform(rng, s.lo[c], s.hi[c]);
        const double ratio = c0 / C_at(y.data());
        if (!std::isfinite(ratio) || ratio == 0 || (ratio < 0 && d % 2 == 0)) continue;
        const double lambda = std::copysign(std::pow(std::abs(ratio), 1.0 / double(d)), ratio);
        X.row(Eigen::Index(filled++)) = lambda * y.transpose();
    }
    return X;
}

}  // namespace

RowMatrix sample_states(const Scheme& scheme, const SampleSpec& spec) {
    const std::size_t n = scheme.phase_space().dim();
    if (spec.count < 1) throw InputError("--count", "must be at least 1");
    if (spec.lo.size() != n || spec.hi.size() != n) throw InputError("--box", "missing: the sampler needs the box");
    switch (spec.kind) {
        case SampleKind::grid:
            return grid(spec, n);
        case SampleKind::box:
            return box(spec, n);
        case SampleKind::casimir:
            return casimir(scheme, spec, n);
    }
    return {};
}

}  // namespace pgi
