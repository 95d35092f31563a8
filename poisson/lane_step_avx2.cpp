// LaneStep for 8 states on AVX2 (Pack4: two vectors of four), compiled with -mavx2 (CMakeLists.txt) and run only
// where the processor has AVX2 (BatchStepper asks it). Only Pack4's instantiations may come out of this file:
// an inline function of another type compiled here with AVX2 instructions could be the copy the linker keeps
// for the whole program (tests/lane_isa.sh checks the object's weak symbols).
#include "poisson/lane_step.ipp"
#include "poisson/realisation_lanes.ipp"

namespace pgi {

template class LaneStep<2, lanes::Pack4>;
template class LaneStep<3, lanes::Pack4>;
template class LaneStep<4, lanes::Pack4>;
template class LaneStep<6, lanes::Pack4>;
PGI_REALISATION_LANES(lanes::Pack4)

}  // namespace pgi
