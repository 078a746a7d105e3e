#include <gshell/quality/triangle_intersections.h>

#include "quality/check_mesh_input.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/Intersections_3/Point_3_Point_3.h>
#include <CGAL/Intersections_3/Point_3_Segment_3.h>
#include <CGAL/Intersections_3/Point_3_Triangle_3.h>
#include <CGAL/Intersections_3/Segment_3_Segment_3.h>
#include <CGAL/Intersections_3/Segment_3_Triangle_3.h>
#include <CGAL/Intersections_3/Triangle_3_Triangle_3.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstdint>

namespace gshell {
namespace {

// Inexact constructions are fine: only predicates are evaluated, and those are exact.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Segment = Kernel::Segment_3;
using Triangle = Kernel::Triangle_3;

// A face as the closed point set it covers. CGAL's triangle tests require non-degenerate
// triangles, so collinear corners become the segment (or point) they span.
struct FaceShape {
  int dim = 2; // 2 triangle p[0..2], 1 segment p[0..1], 0 point p[0]
  std::array<Point, 3> p;
};

FaceShape face_shape(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::Index f) {
  FaceShape s;
  for (int k = 0; k < 3; ++k) s.p[k] = Point(V(F(f, k), 0), V(F(f, k), 1), V(F(f, k), 2));
  if (!CGAL::collinear(s.p[0], s.p[1], s.p[2])) return s;
  // Along a line the lexicographic order is the order on the line, so its extremes span it.
  Point lo = s.p[0], hi = s.p[0];
  for (int k = 1; k < 3; ++k) {
    if (CGAL::compare_xyz(s.p[k], lo) == CGAL::SMALLER) lo = s.p[k];
    if (CGAL::compare_xyz(s.p[k], hi) == CGAL::LARGER) hi = s.p[k];
  }
  s.dim = (lo == hi) ? 0 : 1;
  s.p = {lo, hi, hi};
  return s;
}

std::vector<FaceShape> face_shapes(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  std::vector<FaceShape> shapes(static_cast<std::size_t>(F.rows()));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows(), 4096), [&](const auto& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) shapes[f] = face_shape(V, F, f);
  });
  return shapes;
}

bool shapes_intersect(const FaceShape& a, const FaceShape& b) {
  if (a.dim < b.dim) return shapes_intersect(b, a);
  const Triangle ta(a.p[0], a.p[1], a.p[2]);
  switch (a.dim * 3 + b.dim) {
    case 8: return CGAL::do_intersect(ta, Triangle(b.p[0], b.p[1], b.p[2]));
    case 7: return CGAL::do_intersect(ta, Segment(b.p[0], b.p[1]));
    case 6: return CGAL::do_intersect(ta, b.p[0]);
    case 4: return CGAL::do_intersect(Segment(a.p[0], a.p[1]), Segment(b.p[0], b.p[1]));
    case 3: return CGAL::do_intersect(Segment(a.p[0], a.p[1]), b.p[0]);
    default: return a.p[0] == b.p[0];
  }
}

// Axis-aligned box of a face, closed. Corner coordinates are the vertex doubles themselves, so
// the boxes are exact and no intersecting pair can be missed.
struct FaceBox : CGAL::Box_intersection_d::Box_d<double, 3, CGAL::Box_intersection_d::ID_NONE> {
  using Base = CGAL::Box_intersection_d::Box_d<double, 3, CGAL::Box_intersection_d::ID_NONE>;
  std::size_t key = 0; // unique over all boxes of one search (ties are broken by it)
  FaceBox() = default;
  FaceBox(double lo[3], double hi[3], std::size_t k) : Base(lo, hi), key(k) {}
  std::size_t id() const { return key; }
};

std::vector<FaceBox> face_boxes(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                std::size_t key_offset) {
  std::vector<FaceBox> boxes(static_cast<std::size_t>(F.rows()));
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows(), 4096), [&](const auto& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      double lo[3], hi[3];
      for (int d = 0; d < 3; ++d) {
        const double x = V(F(f, 0), d), y = V(F(f, 1), d), z = V(F(f, 2), d);
        lo[d] = std::min({x, y, z});
        hi[d] = std::max({x, y, z});
      }
      boxes[f] = FaceBox(lo, hi, key_offset + static_cast<std::size_t>(f));
    }
  });
  return boxes;
}

bool share_vertex(const Eigen::MatrixXi& F, Eigen::Index f, Eigen::Index g) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (F(f, i) == F(g, j)) return true;
  return false;
}

using Pairs = std::vector<std::pair<int, int>>;

// Runs the exact test on every candidate pair in parallel and keeps those that intersect.
Pairs keep_intersecting(const Pairs& candidates, const std::vector<FaceShape>& shapes1,
                        const std::vector<FaceShape>& shapes2) {
  std::vector<std::uint8_t> hit(candidates.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, candidates.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i)
      hit[i] = shapes_intersect(shapes1[candidates[i].first], shapes2[candidates[i].second]);
  });
  Pairs result;
  for (std::size_t i = 0; i < candidates.size(); ++i)
    if (hit[i]) result.push_back(candidates[i]);
  std::sort(result.begin(), result.end());
  return result;
}

} // namespace

Pairs self_intersecting_pairs(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  detail::check_triangle_mesh(V, F, "self-intersection test");
  std::vector<FaceBox> boxes = face_boxes(V, F, 0);
  Pairs candidates;
  CGAL::box_self_intersection_d(
      boxes.begin(), boxes.end(),
      [&](const FaceBox& a, const FaceBox& b) {
        const auto f = static_cast<int>(a.key), g = static_cast<int>(b.key);
        if (!share_vertex(F, f, g)) candidates.emplace_back(std::min(f, g), std::max(f, g));
      },
      std::ptrdiff_t(10), CGAL::Box_intersection_d::CLOSED);
  const std::vector<FaceShape> shapes = face_shapes(V, F);
  return keep_intersecting(candidates, shapes, shapes);
}

int count_self_intersections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  return static_cast<int>(self_intersecting_pairs(V, F).size());
}

Pairs intersecting_pairs_between(const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F1,
                                 const Eigen::MatrixXd& V2, const Eigen::MatrixXi& F2) {
  detail::check_triangle_mesh(V1, F1, "intersection test (first mesh)");
  detail::check_triangle_mesh(V2, F2, "intersection test (second mesh)");
  const auto m1 = static_cast<std::size_t>(F1.rows());
  std::vector<FaceBox> boxes1 = face_boxes(V1, F1, 0);
  std::vector<FaceBox> boxes2 = face_boxes(V2, F2, m1);
  Pairs candidates;
  CGAL::box_intersection_d(
      boxes1.begin(), boxes1.end(), boxes2.begin(), boxes2.end(),
      [&](const FaceBox& a, const FaceBox& b) {
        // Keys of mesh 2 are offset by m1, which also tells the ranges apart.
        const FaceBox& b1 = a.key < m1 ? a : b;
        const FaceBox& b2 = a.key < m1 ? b : a;
        candidates.emplace_back(static_cast<int>(b1.key), static_cast<int>(b2.key - m1));
      },
      std::ptrdiff_t(10), CGAL::Box_intersection_d::CLOSED);
  return keep_intersecting(candidates, face_shapes(V1, F1), face_shapes(V2, F2));
}

int count_intersections_between(const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F1,
                                const Eigen::MatrixXd& V2, const Eigen::MatrixXi& F2) {
  return static_cast<int>(intersecting_pairs_between(V1, F1, V2, F2).size());
}

} // namespace gshell
