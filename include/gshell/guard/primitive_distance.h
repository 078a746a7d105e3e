#pragma once
// Distances between the two primitives of a contact pair (those of Incremental Potential Contact,
// Li et al. 2020): a point and a triangle, or two segments. Each distance comes with the features
// that realise it (point-point, point-edge, point-face, edge-edge interior) and, in closed form,
// the gradient and Hessian of the squared distance with respect to the pair's 12 coordinates.
//
// Every case is the same problem: the difference of the closest points is r = sum_k a_k x_k, with
// coefficients a affine in at most two free parameters beta (barycentric coordinates of the
// closest points on an edge or in a face), and d^2 = min_beta |r|^2. At the minimiser the gradient
// is 2 a_k r per point (the parameters' own derivative vanishes), and the Hessian is the Schur
// complement f_xx - f_xb f_bb^-1 f_bx of the parameters (docs/contact.md). Clamped parameters
// (the closest point on a segment's end, or on a triangle's edge) become fixed coefficients.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

#include <array>
#include <cstdint>

namespace gshell {

using Vector12d = Eigen::Matrix<double, 12, 1>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;

/// The four points of a pair: a point and a triangle (x[0]; x[1], x[2], x[3]) or two segments
/// (x[0], x[1]; x[2], x[3]). Coordinates of a pair are ordered 3 * point + axis.
using PairPoints = std::array<Eigen::Vector3d, 4>;

enum class PairKind : std::uint8_t { PointTriangle, EdgeEdge };

enum class ClosestFeatures : std::uint8_t {
  PointPoint, ///< two of the points (a triangle corner, or segment ends)
  PointEdge,  ///< a point and the interior of a segment (a triangle edge or one of the segments)
  PointFace,  ///< the point and the interior of the triangle
  EdgeEdge,   ///< interior points of both segments
};

/// The squared distance of a pair and the stencil of its closest points: r = sum_k a[k] x[k] is
/// the difference of the closest points, da[j][k] the derivative of a[k] by free parameter j.
struct PairDistance {
  ClosestFeatures features = ClosestFeatures::PointPoint;
  double squared = 0;  ///< squared distance (model units squared)
  int parameters = 0;  ///< free parameters: 0 point-point, 1 point-edge, 2 point-face, edge-edge
  std::array<double, 4> a{};
  std::array<std::array<double, 4>, 2> da{};
};

/// Distance between the point x[0] and the closed triangle x[1], x[2], x[3]. A triangle whose
/// corners are collinear to ~1e-15 relative (sin^2 of its angle) is measured by its edges: the
/// face formula loses its accuracy there, and the edges differ from the face by less than that.
PairDistance point_triangle_distance(const PairPoints& x);

/// Distance between the closed segments x[0]x[1] and x[2]x[3]. Segments parallel to ~1e-15
/// (sin^2 of their angle) are measured by their ends, for the same reason.
PairDistance edge_edge_distance(const PairPoints& x);

/// point_triangle_distance or edge_edge_distance. Non-finite points give a NaN distance.
PairDistance pair_distance(PairKind kind, const PairPoints& x);

/// pair_distance(kind, x).squared (the same bits), without building the stencil: the fast path
/// of passes over many pairs.
double pair_squared_distance(PairKind kind, const PairPoints& x);

/// d(d^2)/dx at the points the distance was measured at.
Vector12d squared_distance_gradient(const PairPoints& x, const PairDistance& d);

/// d^2(d^2)/dx^2 at the points the distance was measured at, within the current closest-feature
/// case (the one-sided Hessian where the case changes).
Matrix12d squared_distance_hessian(const PairPoints& x, const PairDistance& d);

} // namespace gshell
