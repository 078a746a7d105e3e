#include <gshell/quality/shell_boundary.h>

#include <gshell/error.h>

#include "geometry/vertex_stars.h"

#include <algorithm>
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

  // Boundary half-edges (i -> j in the one face that has the edge): an edge is on the boundary
  // when a single face of i's star has j as a neighbour. Stars are visited in vertex order (the
  // cheap order), then the sides are put in order of appearance in F.
  const detail::VertexStars stars(detail::RowMajorFaces(F), n);
  struct Side {
    int i, j, face, halfedge; // halfedge = 3 * face + corner of i
  };
  std::vector<Side> sides;
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < stars.degree(i); ++c) {
      const int j = stars.corner(i, c).next;
      int faces = 0;
      for (int d = 0; d < stars.degree(i); ++d) faces += stars.corner(i, d).next == j || stars.corner(i, d).prev == j;
      if (faces != 1) continue;
      const int f = stars.corner(i, c).face;
      const int k = F(f, 0) == i ? 0 : F(f, 1) == i ? 1 : 2;
      sides.push_back({i, j, f, 3 * f + k});
    }
  std::sort(sides.begin(), sides.end(), [](const Side& a, const Side& b) { return a.halfedge < b.halfedge; });

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
