// LaneStep for one state (double) and for 8 on SSE2 (Pack); AVX2's Pack4 in lane_step_avx2.cpp.
#include "poisson/lane_step.ipp"
#include "poisson/realisation_lanes.ipp"

namespace pgi {

extern constexpr LaneLayout baseline_lane_layout = lane_layout();

template class LaneStep<2, double>;
template class LaneStep<3, double>;
template class LaneStep<4, double>;
template class LaneStep<6, double>;
template class LaneStep<2, lanes::Pack>;
template class LaneStep<3, lanes::Pack>;
template class LaneStep<4, lanes::Pack>;
template class LaneStep<6, lanes::Pack>;
PGI_REALISATION_LANES(double)
PGI_REALISATION_LANES(lanes::Pack)

}  // namespace pgi
