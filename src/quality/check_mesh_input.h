#pragma once
// Input checks shared by the quality measures (they may be called on any user-given mesh pair).
#include <Eigen/Core>

namespace gshell::detail {

/// Throws InputError("<what>: ...") unless V is n x 3 with finite entries and F is m x 3 with
/// ids in [0, n).
void check_triangle_mesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const char* what);

/// Throws InputError("<what>: ...") unless F is m x 3 with ids in [0, n).
void check_face_indices(const Eigen::MatrixXi& F, Eigen::Index n, const char* what);

/// Throws InputError("<what>: face f repeats vertex v") unless every face has three distinct ids.
void check_distinct_corners(const Eigen::MatrixXi& F, const char* what);

} // namespace gshell::detail
