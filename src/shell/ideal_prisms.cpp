#include <gshell/shell/ideal_prisms.h>

#include <Eigen/Geometry>

namespace gshell {

PrismCorners normal_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta) {
  PrismCorners P(6 * F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d p = V.row(F(f, k));
      P.row(6 * f + k) = p;
      P.row(6 * f + 3 + k) = p + eta * n;
    }
  }
  return P;
}

} // namespace gshell
