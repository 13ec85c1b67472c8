// One build of the lane kernel for one instruction set: CMakeLists.txt compiles this file once per
// set (-DWSMAP_ISA=base|avx2|avx512 with the matching -march), lanesmodule.cpp picks one at run time.
#include <stdexcept>

#include "lanes.hpp"

namespace wsmap_lanes {
namespace WSMAP_ISA {

template <int NM>
static void run_joints(const Args &a, int lanes) {
    switch (lanes) {
        case 4: run_block<NM, 4>(a); break;
        case 8: run_block<NM, 8>(a); break;
        case 16: run_block<NM, 16>(a); break;
        default: throw std::invalid_argument("lanes must be 4, 8 or 16");
    }
}

void run(const Args &a, int lanes) {
    if (a.n == 6) run_joints<6>(a, lanes);
    else if (a.n == 7) run_joints<7>(a, lanes);
    else run_joints<MAX_JOINTS>(a, lanes);
}

// atan2_pos over arrays, as the lanes compute it (tests)
void atan2_array(const double *y, const double *x, double *out, int64_t count) {
    for (int64_t i = 0; i < count; ++i) out[i] = atan2_pos(y[i], x[i]);
}

}  // namespace WSMAP_ISA
}  // namespace wsmap_lanes
