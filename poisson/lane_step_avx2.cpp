// LaneStep for 8 states on AVX2 (Pack4: two vectors of four), compiled with -mavx2 (CMakeLists.txt) and run only
// where the processor has AVX2 (BatchStepper asks it). Only Pack4's kernels may come out of this file with AVX2
// instructions: an inline function of another type compiled here (a std::vector<double> member, say) could be the
// copy the linker keeps for the whole program, and fault where there is no AVX2; so what the kernels need of
// such functions (the scratch's sizing: RealisationEvaluator::lane_scratch) is compiled elsewhere, and ctest
// lane_isa checks the object (tests/lane_isa.sh).
// Eigen aligns its fixed-size types to the widest vector the compiler targets: 32 bytes under -mavx2, 16 in the
// rest of the library, which would give NewtonStepper (it holds fixed-size Eigen types) another layout here.
// Eigen's own switch for mixing SIMD options keeps them at 16 (avx2_lane_layout lets a test compare).
#define EIGEN_MAX_ALIGN_BYTES 16
#include "poisson/lane_step.ipp"
#include "poisson/realisation_lanes.ipp"

namespace pgi {

extern constexpr LaneLayout avx2_lane_layout = lane_layout();

template class LaneStep<2, lanes::Pack4>;
template class LaneStep<3, lanes::Pack4>;
template class LaneStep<4, lanes::Pack4>;
template class LaneStep<6, lanes::Pack4>;
PGI_REALISATION_LANES(lanes::Pack4)

}  // namespace pgi
