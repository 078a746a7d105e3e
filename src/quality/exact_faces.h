#pragma once
// Triangles as exact closed point sets, for the intersection counts and the shell certificate:
// - faces_intersect: do two faces have a common point (touching counts)?
// - faces_intersect_beyond_shared: do two faces of one surface meet anywhere except at the
//   vertices and edges they share (by vertex id)? This is what an embedded surface forbids.
// Every answer is exact: only predicates are evaluated (orientation, collinear order), with
// CGAL's filtered exact predicates on the input doubles; nothing is constructed.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>

namespace gshell::detail {

using ExactKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using ExactPoint = ExactKernel::Point_3;

/// A face with its vertex ids and corners. A face with collinear corners is the segment (or
/// point) they span, so it is never skipped: its point set is tested as it is.
struct ExactFace {
  std::array<int, 3> id;
  std::array<ExactPoint, 3> p;
  std::uint8_t dim = 2;             ///< 2 triangle, 1 segment p[end[0]]-p[end[1]], 0 point p[end[0]]
  std::array<std::uint8_t, 2> end{}; ///< corners spanning a degenerate face

  bool degenerate() const { return dim < 2; }
};

/// Face f of (V, F) (indices checked by the caller).
ExactFace exact_face(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f);

/// Whether the closed point sets of a and b meet (vertex ids are ignored).
bool faces_intersect(const ExactFace& a, const ExactFace& b);

/// The corners two faces have in common by vertex id: a's corner in_a[i] is b's corner in_b[i].
struct SharedCorners {
  int count = 0;
  std::array<std::uint8_t, 3> in_a{}, in_b{};
};

inline SharedCorners shared_corners(const std::array<int, 3>& a, const std::array<int, 3>& b) {
  SharedCorners s;
  for (std::uint8_t i = 0; i < 3; ++i)
    for (std::uint8_t j = 0; j < 3; ++j)
      if (a[i] == b[j] && s.count < 3) {
        s.in_a[s.count] = i;
        s.in_b[s.count] = j;
        ++s.count;
      }
  return s;
}

/// Whether a and b meet outside the vertices and edges they share by id: with no common id,
/// anywhere; with one common vertex p, anywhere but p; with a common edge pq, off the segment pq;
/// two faces on the same three ids meet off their edges unless they are degenerate. Each face's
/// three ids must be distinct; `shared` = shared_corners(a.id, b.id).
bool faces_intersect_beyond_shared(const ExactFace& a, const ExactFace& b, const SharedCorners& shared);

inline bool faces_intersect_beyond_shared(const ExactFace& a, const ExactFace& b) {
  return faces_intersect_beyond_shared(a, b, shared_corners(a.id, b.id));
}

} // namespace gshell::detail
