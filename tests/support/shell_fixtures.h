#pragma once
// Small analytic shells and vertex-id ranges shared by the solver, generation, deformation, embedding,
// texture, pose and hierarchy tests.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/shell.h>

#include <cmath>
#include <numeric>
#include <vector>

namespace gshell::test {

/// `m` as a triangle soup: every face with its own three vertices, in face order (as some
/// exporters write OBJ): the surface cut along every edge.
inline TriMesh triangle_soup(const TriMesh& m) {
  TriMesh s;
  s.V.resize(3 * m.F.rows(), 3);
  s.F.resize(m.F.rows(), 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      s.V.row(3 * f + k) = m.V.row(m.F(f, k));
      s.F(f, k) = static_cast<int>(3 * f + k);
    }
  return s;
}

/// Vertex ids first .. first + count - 1; the base rows of a 2n-vertex shell are
/// vertex_range(0, n), what generation and deformation hold fixed.
inline std::vector<int> vertex_range(int first, int count) {
  std::vector<int> ids(count);
  std::iota(ids.begin(), ids.end(), first);
  return ids;
}

/// Shell over `surface` whose top is the base shifted by eta along +z (exact for a z=0 plane).
inline Shell lifted_shell(const TriMesh& surface, double eta) {
  Shell s;
  s.base = surface.V;
  s.top = surface.V;
  s.top.col(2).array() += eta;
  s.F = surface.F;
  s.thickness = eta;
  return s;
}

/// Two builtin:plane:RES grids `gap` apart in z with normals facing each other (the first at z = 0,
/// normals +z; the second's vertices are the first's shifted by n).
inline TriMesh facing_sheets(int res, double gap) {
  const TriMesh a = make_plane(res);
  TriMesh m;
  const int n = static_cast<int>(a.V.rows());
  m.V.resize(2 * n, 3);
  m.F.resize(2 * a.F.rows(), 3);
  m.V << a.V, a.V;
  m.V.bottomRows(n).col(2).setConstant(gap);
  m.F.topRows(a.F.rows()) = a.F;
  for (int f = 0; f < a.F.rows(); ++f) m.F.row(a.F.rows() + f) << a.F(f, 0) + n, a.F(f, 2) + n, a.F(f, 1) + n;
  return m;
}

/// Two builtin:sphere:LEVEL spheres about the origin, both facing out: radius 1 (vertices
/// 0..n-1) and radius `outer` (n..2n-1), one inside the other as an eye in a head.
inline TriMesh nested_spheres(int level, double outer) {
  const TriMesh a = make_sphere(level);
  const int n = static_cast<int>(a.V.rows());
  TriMesh m;
  m.V.resize(2 * n, 3);
  m.V << a.V, outer * a.V;
  m.F.resize(2 * a.F.rows(), 3);
  m.F << a.F, (a.F.array() + n).matrix();
  return m;
}

/// A unit builtin:sphere:3 (vertices 0..641) and, centred at (3, 0, 0), a builtin:sphere:2 of
/// radius `speck` (vertices 642..803): scan debris beside a model.
inline TriMesh sphere_with_speck(double speck) {
  const TriMesh big = make_sphere(3, 1.0), small = make_sphere(2, speck);
  const int nb = static_cast<int>(big.V.rows()), ns = static_cast<int>(small.V.rows());
  TriMesh m;
  m.V.resize(nb + ns, 3);
  m.V << big.V, small.V.rowwise() + Eigen::RowVector3d(3, 0, 0);
  m.F.resize(big.F.rows() + small.F.rows(), 3);
  m.F << big.F, (small.F.array() + nb).matrix();
  return m;
}

/// A z = 0 grid over [-1, 1]^2 (builtin:plane:RES, normals +z) folded about the y axis into a V
/// of opening angle `degrees`, both halves' normals facing into the V.
inline TriMesh folded_plane(int res, double degrees) {
  TriMesh m = make_plane(res);
  const double half = 0.5 * degrees * M_PI / 180;
  for (int i = 0; i < m.V.rows(); ++i) {
    const double x = m.V(i, 0);
    m.V(i, 0) = x * std::sin(half);
    m.V(i, 2) = std::abs(x) * std::cos(half);
  }
  return m;
}

/// Flat shell of thickness eta over builtin:plane:RES.
inline Shell flat_plane_shell(int res, double eta) { return lifted_shell(make_plane(res), eta); }

/// Offset shell of thickness eta over `surface` (the paper's baseline: vertex normals).
inline Shell offset_shell(const TriMesh& surface, double eta) {
  Shell s;
  s.base = surface.V;
  s.top = offset_top(surface.V, surface.F, eta);
  s.F = surface.F;
  s.thickness = eta;
  return s;
}

/// Offset shell of thickness eta over the unit icosphere of the given level.
inline Shell sphere_shell(int level, double eta) { return offset_shell(make_sphere(level), eta); }

/// generate_shell options for a method and thickness, without the (slow) intersection counts.
inline GenerateOptions generate_options(ShellMethod method, double eta, int iterations = 50) {
  GenerateOptions o;
  o.method = method;
  o.thickness = eta;
  o.solve.max_iterations = iterations;
  o.count_intersections = false;
  return o;
}

} // namespace gshell::test
