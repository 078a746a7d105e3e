#include <gshell/solver/polar_decomposition.h>

#include "solver/polar_3x3.h"

#include <algorithm>

namespace gshell {

Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& F) { return detail::closest_rotation_inline(F); }

void closest_rotations(const Eigen::Matrix3d* F, Eigen::Matrix3d* R, std::size_t count) {
  constexpr int W = detail::kPolarLanes;
  alignas(64) double Fs[9 * W], Rs[9 * W];
  for (std::size_t i0 = 0; i0 < count; i0 += W) {
    const int lanes = static_cast<int>(std::min<std::size_t>(W, count - i0));
    for (int l = 0; l < W; ++l)
      for (int k = 0; k < 9; ++k)
        Fs[k * W + l] = l < lanes ? F[i0 + l](k / 3, k % 3) : (k % 4 == 0 ? 1.0 : 0.0);
    detail::closest_rotations_lanes(Fs, Rs);
    for (int l = 0; l < lanes; ++l)
      for (int k = 0; k < 9; ++k) R[i0 + l](k / 3, k % 3) = Rs[k * W + l];
  }
}

} // namespace gshell
