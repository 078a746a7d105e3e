#include "quality/embedded_stars.h"

#include "geometry/vertex_stars.h"
#include "quality/filtered_orientation.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <initializer_list>

namespace gshell::detail {
namespace {

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

// Half-open angle classes of the direction from c to p: `upper` for angles in [0, pi), `zero`
// for angle 0 (along the first axis).
struct Direction {
  bool upper, zero;
};

Direction direction(double cx, double cy, double px, double py) {
  const bool on_axis = py == cy, right = px > cx;
  return {py > cy || (on_axis && right), on_axis && right};
}

using RowMajorPoints = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

bool projects_one_to_one(const RowMajorPoints& V, const VertexStars& stars, int v) {
  const int k = stars.degree(v);
  const double* c = V.row(v).data();
  // Any coordinate plane gives an exact test; the one facing the first face usually works.
  const auto& first = stars.corner(v, 0);
  const double *p0 = V.row(first.next).data(), *q0 = V.row(first.prev).data();
  const double u[3] = {p0[0] - c[0], p0[1] - c[1], p0[2] - c[2]}, w[3] = {q0[0] - c[0], q0[1] - c[1], q0[2] - c[2]};
  const double normal[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
  int axis = 0;
  for (int d = 1; d < 3; ++d)
    if (std::abs(normal[d]) > std::abs(normal[axis])) axis = d;
  // (a, b, axis) is a right-handed frame: faces whose normal points along +axis turn
  // counter-clockwise in (a, b); swapping a and b mirrors the view from -axis.
  int a = (axis + 1) % 3, b = (axis + 2) % 3;
  if (normal[axis] < 0) std::swap(a, b);
  int winding = 0;
  for (int i = 0; i < k; ++i) {
    const auto& f = stars.corner(v, i);
    const double *p = V.row(f.next).data(), *q = V.row(f.prev).data();
    if (orientation_sign(c[a], c[b], p[a], p[b], q[a], q[b]) <= 0) return false;
    // The sector from p to q (counter-clockwise, less than pi) covers angle 0, half-open: it
    // starts there, or it crosses from the lower half-plane into the upper one past angle 0.
    const Direction dp = direction(c[a], c[b], p[a], p[b]), dq = direction(c[a], c[b], q[a], q[b]);
    winding += dp.zero || (!dp.upper && dq.upper && !dq.zero);
  }
  return winding == 1;
}

// Flags of the n vertices of `stars` at the positions of each matrix in `positions`, one block
// of n entries per matrix; a null matrix leaves its block 0.
std::vector<char> flag_stars(const VertexStars& stars, int n, std::initializer_list<const Eigen::MatrixXd*> positions) {
  std::vector<char> embedded(n * positions.size(), 0);
  std::vector<RowMajorPoints> points; // a vertex's coordinates in one cache line
  for (const Eigen::MatrixXd* V : positions) points.emplace_back(V ? RowMajorPoints(*V) : RowMajorPoints());
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 2048), [&](const tbb::blocked_range<int>& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      if (!single_closed_fan(stars, v)) continue;
      for (std::size_t block = 0; block < points.size(); ++block)
        if (points[block].rows() > 0) embedded[n * block + v] = projects_one_to_one(points[block], stars, v);
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
                                       const Eigen::MatrixXi& F, bool base_stars) {
  const int n = static_cast<int>(base.rows());
  return flag_stars(VertexStars(RowMajorFaces(F), n), n, {base_stars ? &base : nullptr, &top});
}

} // namespace gshell::detail
