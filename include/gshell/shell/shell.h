#pragma once
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

#include <string>

namespace gshell {

/// A shell: base and top surfaces with the same faces and vertex order (top i over base i).
struct Shell {
  Eigen::MatrixXd base;   ///< n x 3
  Eigen::MatrixXd top;    ///< n x 3
  Eigen::MatrixXi F;      ///< m x 3
  double thickness = 0;   ///< eta, model units

  int num_base_vertices() const { return static_cast<int>(base.rows()); }
  /// All 2n shell vertices: base rows 0..n-1, then top rows n..2n-1 (the tets' vertex ids).
  Eigen::MatrixXd vertices() const {
    Eigen::MatrixXd X(2 * base.rows(), 3);
    X << base, top;
    return X;
  }
};

/// Checks a shell filled in by hand before a solver indexes it: base and top both n x 3 with finite
/// coordinates, F m x 3 with ids in [0, n), and (with `need_thickness`) a positive finite
/// thickness. \throws InputError "NAME: problem", e.g. "the rest shell: face 4 has vertex id 900
/// (the base has 162 vertices)".
void check_shell(const Shell& shell, const std::string& name, bool need_thickness = true);

} // namespace gshell
