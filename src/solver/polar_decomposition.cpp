#include <gshell/solver/polar_decomposition.h>

#include "solver/polar_3x3.h"
#include "solver/simd_dispatch.h"

#include <algorithm>

namespace gshell {

namespace {

GSHELL_SIMD_KERNEL void closest_rotations_body(const Eigen::Matrix3d* F, Eigen::Matrix3d* R, std::size_t count) {
  constexpr int W = detail::kPolarLanes;
  alignas(64) double Fs[9 * W], Rs[9 * W];
  for (std::size_t i0 = 0; i0 < count; i0 += W) {
    const int lanes = static_cast<int>(std::min<std::size_t>(W, count - i0));
    // Entry (r, c) is at r + 3 c of a column-major Eigen matrix and at 3 r + c of a lane block.
    for (int l = 0; l < W; ++l)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          Fs[(3 * r + c) * W + l] = l < lanes ? F[i0 + l].data()[r + 3 * c] : (r == c ? 1.0 : 0.0);
    detail::closest_rotations_lanes(Fs, Rs);
    for (int l = 0; l < lanes; ++l)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R[i0 + l].data()[r + 3 * c] = Rs[(3 * r + c) * W + l];
  }
}

GSHELL_SIMD_DISPATCH(void, closest_rotations_simd, closest_rotations_body,
                     (const Eigen::Matrix3d* F, Eigen::Matrix3d* R, std::size_t count), (F, R, count))

} // namespace

Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& F) { return detail::closest_rotation_inline(F); }

void closest_rotations(const Eigen::Matrix3d* F, Eigen::Matrix3d* R, std::size_t count) {
  closest_rotations_simd(F, R, count);
}

} // namespace gshell
