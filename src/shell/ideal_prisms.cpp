#include <gshell/shell/ideal_prisms.h>

#include "quality/check_mesh_input.h"

#include <gshell/error.h>

#include <Eigen/Geometry>

#include <tbb/parallel_for.h>

#include <cmath>

namespace gshell {

PrismCorners normal_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta) {
  if (V.rows() > 0 && V.cols() != 3) throw InputError("normal_prisms: V must be n x 3");
  detail::check_face_indices(F, V.rows(), "normal_prisms");
  if (!std::isfinite(eta)) throw InputError("normal_prisms: eta must be finite");
  PrismCorners P(6 * F.rows(), 3);
  // In parallel: at millions of faces this is also the first touch of P's pages.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows(), 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      const Eigen::Vector3d lift = normal_prism_lift(a, b, c, eta);
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d p = V.row(F(f, k));
        P.row(6 * f + k) = p;
        P.row(6 * f + 3 + k) = p + lift;
      }
    }
  });
  return P;
}

} // namespace gshell
