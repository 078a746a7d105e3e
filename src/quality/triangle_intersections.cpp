#include <gshell/quality/triangle_intersections.h>

#include "quality/check_mesh_input.h"
#include "quality/face_bvh.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Intersections_3/Point_3_Point_3.h>
#include <CGAL/Intersections_3/Point_3_Segment_3.h>
#include <CGAL/Intersections_3/Point_3_Triangle_3.h>
#include <CGAL/Intersections_3/Segment_3_Segment_3.h>
#include <CGAL/Intersections_3/Segment_3_Triangle_3.h>
#include <CGAL/Intersections_3/Triangle_3_Triangle_3.h>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>

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

FaceShape face_shape(const Eigen::MatrixXd& V, const Eigen::Vector3i& corners) {
  FaceShape s;
  for (int k = 0; k < 3; ++k) s.p[k] = Point(V(corners[k], 0), V(corners[k], 1), V(corners[k], 2));
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

// The faces of a mesh in the slot order of its tree: vertex ids and shapes.
struct SlotFaces {
  std::vector<Eigen::Vector3i> corners;
  std::vector<FaceShape> shapes;

  SlotFaces(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const detail::FaceBvh& bvh)
      : corners(bvh.num_faces()), shapes(bvh.num_faces()) {
    const std::vector<int>& face = bvh.faces_in_leaf_order();
    tbb::parallel_for(tbb::blocked_range<int>(0, bvh.num_faces(), 4096), [&](const auto& r) {
      for (int s = r.begin(); s < r.end(); ++s) {
        corners[s] = F.row(face[s]).transpose();
        shapes[s] = face_shape(V, corners[s]);
      }
    });
  }
};

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

bool share_vertex(const Eigen::Vector3i& a, const Eigen::Vector3i& b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) return true;
  return false;
}

using Pairs = std::vector<std::pair<int, int>>;

// Collects pairs found concurrently (one list per thread), then merges and sorts them.
class PairCollector {
public:
  void add(int f, int g) { found_.local().emplace_back(f, g); }
  Pairs sorted() {
    Pairs all;
    for (const Pairs& part : found_) all.insert(all.end(), part.begin(), part.end());
    std::sort(all.begin(), all.end());
    return all;
  }

private:
  tbb::enumerable_thread_specific<Pairs> found_;
};

} // namespace

Pairs self_intersecting_pairs(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  detail::check_triangle_mesh(V, F, "self-intersection test");
  const detail::FaceBvh bvh(V, F, detail::FaceBvh::Use::pairs);
  const SlotFaces faces(V, F, bvh);
  const std::vector<int>& face = bvh.faces_in_leaf_order();
  PairCollector pairs;
  bvh.for_each_overlapping_pair([&](int s, int t) {
    if (!share_vertex(faces.corners[s], faces.corners[t]) &&
        shapes_intersect(faces.shapes[s], faces.shapes[t]))
      pairs.add(std::min(face[s], face[t]), std::max(face[s], face[t]));
  });
  return pairs.sorted();
}

int count_self_intersections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  return static_cast<int>(self_intersecting_pairs(V, F).size());
}

Pairs intersecting_pairs_between(const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F1,
                                 const Eigen::MatrixXd& V2, const Eigen::MatrixXi& F2) {
  detail::check_triangle_mesh(V1, F1, "intersection test (first mesh)");
  detail::check_triangle_mesh(V2, F2, "intersection test (second mesh)");
  const detail::FaceBvh bvh1(V1, F1, detail::FaceBvh::Use::pairs);
  const detail::FaceBvh bvh2(V2, F2, detail::FaceBvh::Use::pairs);
  const SlotFaces faces1(V1, F1, bvh1), faces2(V2, F2, bvh2);
  const std::vector<int>&face1 = bvh1.faces_in_leaf_order(), &face2 = bvh2.faces_in_leaf_order();
  PairCollector pairs;
  bvh1.for_each_overlapping_pair(bvh2, [&](int s1, int s2) {
    if (shapes_intersect(faces1.shapes[s1], faces2.shapes[s2])) pairs.add(face1[s1], face2[s2]);
  });
  return pairs.sorted();
}

int count_intersections_between(const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F1,
                                const Eigen::MatrixXd& V2, const Eigen::MatrixXi& F2) {
  return static_cast<int>(intersecting_pairs_between(V1, F1, V2, F2).size());
}

} // namespace gshell
