#pragma once
// Ideal (distortion-free target) prisms, one per face (docs/design.md "Ideal prisms").
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace gshell {

/// Corners of the ideal prisms as a 6m x 3 matrix: rows 6f..6f+2 are face f's base corners in
/// face order, rows 6f+3..6f+5 the top corners above them (same layout as prism_tet_corners).
using PrismCorners = Eigen::MatrixXd;

/// What a normal prism's top corners add to its base corners (a, b, c, counter-clockwise): eta
/// times the face's unit normal. The one definition of the normal prism, shared by
/// normal_prisms, normal_prism_rest_tets and the deformer's replacement rest shapes.
inline Eigen::Vector3d normal_prism_lift(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                         double eta) {
  return eta * (b - a).cross(c - a).normalized();
}

/// Normal prisms: top triangle = base triangle shifted by eta along the face's unit normal.
/// (A negative eta gives the prisms below the base, turned inside out as rest shapes.)
/// \throws InputError when V is not n x 3, F not m x 3 with ids in [0, n), or eta is not finite.
PrismCorners normal_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta);

} // namespace gshell
