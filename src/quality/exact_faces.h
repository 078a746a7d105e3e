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

/// The face with these ids and corners (its dimension decided exactly).
ExactFace exact_face(const std::array<int, 3>& id, const std::array<ExactPoint, 3>& p);

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

/// A face's slab along a direction n close to its normal (scaled so that max |n_i| = 1): the
/// range [lo, hi] of the rounded n.p over its corners. Two faces are disjoint when the corners of
/// one lie beyond the other's slab by more than the rounding of these dot products can explain
/// (slabs_separate): a cheap exact rejection for the many pairs of a thin shell whose boxes meet
/// while they lie apart along their normals (a top face over the base faces below it). Any n
/// gives a correct answer (a plane along n then separates them); a good one decides more pairs.
struct FaceSlab {
  double n[3] = {0, 0, 0};
  double lo = 0, hi = 0;
};

FaceSlab face_slab(const ExactFace& f);

/// The margin of slabs_separate for faces whose coordinates are at most `max_abs` in magnitude:
/// bounds the rounding error of a slab's ends plus that of the dot product compared with them.
/// Infinite (nothing is ever separated) when the products could overflow.
double slab_margin(double max_abs);

/// True when a and b (with their face_slab) are disjoint, shown exactly: all of b's corners lie
/// beyond a's slab by more than `margin` (slab_margin of their largest coordinate), or all of a's
/// beyond b's. False: undecided (the faces may or may not meet).
bool slabs_separate(const ExactFace& a, const FaceSlab& sa, const ExactFace& b, const FaceSlab& sb, double margin);

} // namespace gshell::detail
