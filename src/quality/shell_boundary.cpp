#include <gshell/quality/shell_boundary.h>

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>

#include <string>

namespace gshell {

ShellBoundary shell_boundary(const Eigen::MatrixXi& F, int n) {
  const int m = static_cast<int>(F.rows());
  if (F.cols() != 3 && m > 0) throw InputError("shell_boundary: faces must be an m x 3 matrix");
  for (int f = 0; f < m; ++f) {
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        throw InputError("shell_boundary: face " + std::to_string(f) + " has vertex id " + std::to_string(F(f, k)) +
                         " outside 0.." + std::to_string(n - 1));
    if (F(f, 0) == F(f, 1) || F(f, 1) == F(f, 2) || F(f, 2) == F(f, 0))
      throw InputError("shell_boundary: face " + std::to_string(f) + " repeats a vertex");
  }

  // Boundary half-edges (i -> j in the one face that has the edge), in order of appearance.
  const EdgeIncidence incidence = edge_incidence(F, n);
  struct Side {
    int i, j, face;
  };
  std::vector<Side> sides;
  for (int e = 0; e < incidence.num_edges(); ++e) {
    if (incidence.valence(e) != 1) continue;
    const int h = incidence.halfedges[incidence.offsets[e]];
    const int f = h / 3, k = h % 3;
    sides.push_back({F(f, k), F(f, (k + 1) % 3), f});
  }

  ShellBoundary b;
  const int rows = 2 * m + 2 * static_cast<int>(sides.size());
  b.F.resize(rows, 3);
  b.part.resize(rows);
  b.face.resize(rows);
  for (int f = 0; f < m; ++f) {
    b.F.row(f) << F(f, 0), F(f, 2), F(f, 1);
    b.part[f] = BoundaryPart::Base;
    b.face[f] = f;
    b.F.row(m + f) = F.row(f).array() + n;
    b.part[m + f] = BoundaryPart::Top;
    b.face[m + f] = f;
  }
  int row = 2 * m;
  for (const Side& s : sides) {
    // Quad base i, base j, top j, top i (outward for i -> j running counter-clockwise in its
    // face), cut along base(min(i,j)) - top(max(i,j)) like the prism tets.
    if (s.i < s.j) {
      b.F.row(row) << s.i, s.j, n + s.j;
      b.F.row(row + 1) << s.i, n + s.j, n + s.i;
    } else {
      b.F.row(row) << s.i, s.j, n + s.i;
      b.F.row(row + 1) << s.j, n + s.j, n + s.i;
    }
    for (int r = row; r < row + 2; ++r) {
      b.part[r] = BoundaryPart::Wall;
      b.face[r] = s.face;
    }
    row += 2;
  }
  return b;
}

} // namespace gshell
