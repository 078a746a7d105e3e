#pragma once
// Small analytic shells shared by the deformation, embedding and texture tests.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/shell.h>

namespace gshell::test {

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

/// Flat shell of thickness eta over builtin:plane:RES.
inline Shell flat_plane_shell(int res, double eta) { return lifted_shell(make_plane(res), eta); }

/// Offset shell of thickness eta over the unit icosphere of the given level.
inline Shell sphere_shell(int level, double eta) {
  const TriMesh sphere = make_sphere(level);
  Shell s;
  s.base = sphere.V;
  s.top = offset_top(sphere.V, sphere.F, eta);
  s.F = sphere.F;
  s.thickness = eta;
  return s;
}

} // namespace gshell::test
