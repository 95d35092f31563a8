#pragma once
// Seeded initial states for `pgi ensemble --sample`: a grid, uniform in a box, or on a Casimir's level set.
#include "scheme/ensemble.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace pgi {

enum class SampleKind { grid, box, casimir };

struct SampleSpec {
    SampleKind kind = SampleKind::box;
    std::size_t count = 0;                   // rows (grid: g^n, g points per coordinate)
    std::uint64_t seed = 0;                  // box, casimir: the mt19937_64's seed
    std::vector<double> lo, hi;              // the box, one bound per coordinate
    std::optional<Eigen::VectorXd> through;  // casimir: the level set through this state
};

/// "grid" | "box" | "casimir"; InputError otherwise.
SampleKind parse_sample_kind(const std::string& text);
/// "lo,hi" (every coordinate) or "lo1,hi1,...,lon,hin" into spec.lo, spec.hi; InputError unless lo < hi, finite.
void parse_box(const std::string& text, std::size_t n, SampleSpec& spec);

/// count x n states. grid: g = count^(1/n) points per coordinate from lo to hi (count must be g^n; g = 1
/// is the box's centre), the last coordinate fastest. box: uniform in the box, u = (mt19937_64() >> 11) 2^-53
/// per coordinate, so a seed gives the same states everywhere. casimir: box points y rescaled to lambda y
/// with C(lambda y) = C(through), which needs exactly one Casimir, homogeneous of degree d (C(lambda y) =
/// lambda^d C(y)), and C(through) != 0; points where no real lambda exists (C(y) of the other sign for even
/// d, or C(y) = 0) are drawn again, up to 100 count draws. The states lie on the level set, outside the box
/// possibly; their law on it is not the surface measure. Throws InputError naming the option at fault.
RowMatrix sample_states(const Scheme& scheme, const SampleSpec& spec);

}  // namespace pgi
