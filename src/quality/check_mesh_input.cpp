#include "quality/check_mesh_input.h"

#include <gshell/error.h>

#include <string>

namespace gshell::detail {

void check_triangle_mesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const char* what) {
  const std::string name(what);
  if (V.rows() > 0 && V.cols() != 3)
    throw InputError(name + ": vertex matrix has " + std::to_string(V.cols()) + " columns, expected 3");
  if (F.rows() > 0 && F.cols() != 3)
    throw InputError(name + ": face matrix has " + std::to_string(F.cols()) + " columns, expected 3");
  if (V.rows() > 0 && !V.allFinite())
    throw InputError(name + ": non-finite vertex coordinate");
  check_face_indices(F, V.rows(), what);
}

void check_face_indices(const Eigen::MatrixXi& F, Eigen::Index n, const char* what) {
  if (F.rows() > 0 && F.cols() != 3)
    throw InputError(std::string(what) + ": face matrix has " + std::to_string(F.cols()) + " columns, expected 3");
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        throw InputError(std::string(what) + ": face " + std::to_string(f) + " refers to vertex " +
                         std::to_string(F(f, k)) + " but there are " + std::to_string(n) + " vertices");
}

void check_distinct_corners(const Eigen::MatrixXi& F, const char* what) {
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) == F(f, (k + 1) % 3))
        throw InputError(std::string(what) + ": face " + std::to_string(f) + " repeats vertex " +
                         std::to_string(F(f, k)));
}

} // namespace gshell::detail
