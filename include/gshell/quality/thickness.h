#pragma once
// Per-vertex thickness of a shell (docs/design.md "Quality measures"): how far each top vertex is
// from the base surface. Divide by eta for the relative thickness of the report.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// Distance (model units) from each top vertex to the base surface, i.e. to the closest point on
/// any base triangle (faces F over the rows of `base`); one entry per row of `top`. Degenerate
/// base faces count as the segment or point they cover. Usually top vertex i sits over base
/// vertex i (same F): then only the faces at base vertex i and those top vertex i lies above
/// (strictly on the positive side of their plane) count. The layer's thickness is measured
/// along its own side of the base: a top that comes close to the back of another part of the
/// base (an inner sphere's top under an outer sphere, one sheet's top under another) is not thin.
/// `top` may have any number of rows; unpaired rows are measured to all faces.
/// \throws InputError when base is not n x 3 or not finite, F not m x 3 with ids in [0, n), F
///         empty, or top not finite k x 3.
Eigen::VectorXd vertex_thickness(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                 const Eigen::MatrixXd& top);

} // namespace gshell
