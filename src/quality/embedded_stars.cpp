#include "quality/embedded_stars.h"

#include "geometry/vertex_stars.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <initializer_list>

namespace gshell::detail {
namespace {

using Point2 = CGAL::Exact_predicates_inexact_constructions_kernel::Point_2;

// The longest star seen on real meshes has a few dozen faces; longer ones are left to the tests.
constexpr int kMaxStar = 64;

// Whether the link of v (edges next -> prev of its faces) is one closed cycle through all faces.
bool single_closed_fan(const VertexStars& stars, int v) {
  const int k = stars.degree(v);
  if (k < 3 || k > kMaxStar) return false;
  int at = stars.corner(v, 0).prev, steps = 1;
  const int start = stars.corner(v, 0).next;
  while (at != start) {
    int found = -1;
    for (int i = 0; i < k; ++i)
      if (stars.corner(v, i).next == at) {
        if (found >= 0) return false; // two faces leave the same edge: not a manifold fan
        found = i;
      }
    if (found < 0 || ++steps > k) return false;
    at = stars.corner(v, found).prev;
  }
  return steps == k;
}

// Half-open angle classes around the centre c in the projected plane: `upper` for directions
// in [0, pi), `zero` for the direction of the positive first axis (angle 0).
struct Direction {
  bool upper, zero;
};

Direction direction(const Point2& c, const Point2& p) {
  const bool on_axis = p.y() == c.y(), right = p.x() > c.x();
  return {p.y() > c.y() || (on_axis && right), on_axis && right};
}

using RowMajorPoints = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

bool projects_one_to_one(const RowMajorPoints& V, const VertexStars& stars, int v) {
  const int k = stars.degree(v);
  const Eigen::Vector3d c = V.row(v);
  Eigen::Vector3d normal = Eigen::Vector3d::Zero(); // any axis is exact; this one usually works
  for (int i = 0; i < k; ++i) {
    const auto& f = stars.corner(v, i);
    normal += (V.row(f.next).transpose() - c).cross(V.row(f.prev).transpose() - c);
  }
  int axis = 0;
  normal.cwiseAbs().maxCoeff(&axis);
  // (a, b, axis) is a right-handed frame: faces whose normal points along +axis turn
  // counter-clockwise in (a, b); swapping a and b mirrors the view from -axis.
  int a = (axis + 1) % 3, b = (axis + 2) % 3;
  if (normal[axis] < 0) std::swap(a, b);
  auto project = [&](int w) { return Point2(V(w, a), V(w, b)); };
  const Point2 centre = project(v);
  int winding = 0;
  for (int i = 0; i < k; ++i) {
    const auto& f = stars.corner(v, i);
    const Point2 p = project(f.next), q = project(f.prev);
    if (CGAL::orientation(centre, p, q) != CGAL::LEFT_TURN) return false;
    // The sector from p to q (counter-clockwise, less than pi) covers angle 0, half-open: it
    // starts there, or it crosses from the lower half-plane into the upper one past angle 0.
    const Direction dp = direction(centre, p), dq = direction(centre, q);
    winding += dp.zero || (!dp.upper && dq.upper && !dq.zero);
  }
  return winding == 1;
}

// Flags of the vertices of `stars` at the positions of each matrix in `positions`, one block of
// stars.size() entries per matrix.
std::vector<char> flag_stars(const VertexStars& stars, int n, std::initializer_list<const Eigen::MatrixXd*> positions) {
  std::vector<char> embedded(n * positions.size(), 0);
  std::vector<RowMajorPoints> points; // a vertex's coordinates in one cache line
  for (const Eigen::MatrixXd* V : positions) points.emplace_back(*V);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 2048), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      if (!single_closed_fan(stars, v)) continue;
      for (std::size_t block = 0; block < points.size(); ++block)
        embedded[n * block + v] = projects_one_to_one(points[block], stars, v);
    }
  });
  return embedded;
}

} // namespace

std::vector<char> embedded_stars(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  const int n = static_cast<int>(V.rows());
  return flag_stars(VertexStars(RowMajorFaces(F), n), n, {&V});
}

std::vector<char> embedded_shell_stars(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                       const Eigen::MatrixXi& F) {
  const int n = static_cast<int>(base.rows());
  return flag_stars(VertexStars(RowMajorFaces(F), n), n, {&base, &top});
}

} // namespace gshell::detail
