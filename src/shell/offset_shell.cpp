#include <gshell/shell/offset_shell.h>

#include "quality/check_mesh_input.h"

#include <gshell/error.h>

#include <Eigen/Geometry>

#include <cmath>

namespace gshell {

Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  if (V.rows() > 0 && V.cols() != 3) throw InputError("vertex_normals: V must be n x 3");
  detail::check_face_indices(F, V.rows(), "vertex_normals");
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(V.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d area_normal = (b - a).cross(c - a); // length = twice the area
    for (int k = 0; k < 3; ++k) N.row(F(f, k)) += area_normal.transpose();
  }
  for (Eigen::Index i = 0; i < N.rows(); ++i) {
    const double len = N.row(i).norm();
    if (len > 0) N.row(i) /= len;
  }
  return N;
}

Eigen::MatrixXd offset_top(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta) {
  if (!std::isfinite(eta)) throw InputError("offset_top: eta must be finite");
  return V + eta * vertex_normals(V, F);
}

} // namespace gshell
