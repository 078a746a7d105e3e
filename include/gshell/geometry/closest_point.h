#pragma once
// Closest points on segments and triangles: the thickness measure (quality/thickness.h, through
// the face hierarchy) and point location outside a tet mesh (deform/tet_locator.h) share them.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// Closest point to p on the segment from a to b (a when a == b).
Eigen::Vector3d closest_point_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                         const Eigen::Vector3d& b);

/// True when the corners are collinear up to rounding: sin^2 of the angle at a below 1e-24
/// (within ~1e-12 edge lengths of a segment, where the plane-projection formula loses its
/// accuracy), or two corners coincide.
bool triangle_is_flat(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Closest point to p on the closed triangle (a, b, c), by the Voronoi regions of its corners,
/// edges and face. A flat triangle (triangle_is_flat) is taken as the segments of its edges.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// The same with triangle_is_flat(a, b, c) known already (e.g. computed once per face).
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c, bool flat);

} // namespace gshell
