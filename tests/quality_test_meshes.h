#pragma once
// Meshes for the quality tests, from the builtin generators.
#include <gshell/geometry/builtin_mesh.h>

#include <Eigen/Core>

namespace gshell::test {

/// Icosphere (builtin:sphere) of `radius` around `centre`: closed, welded, vertices on the sphere.
inline TriMesh icosphere(int level, double radius = 1.0,
                         const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  TriMesh m = make_sphere(level, radius);
  m.V.rowwise() += centre.transpose();
  return m;
}

/// Square [-s, s]^2 in the plane z = 0 (builtin:plane), res x res quads.
inline TriMesh grid_plane(int res, double s = 1.0) { return make_plane(res, s); }

} // namespace gshell::test
