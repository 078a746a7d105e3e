#include "quality/closest_point_tree.h"

#include <algorithm>
#include <limits>

namespace gshell::detail {
namespace {

constexpr int kLeafSize = 4;

double segment_squared_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                const Eigen::Vector3d& q) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - q).squaredNorm();
}

} // namespace

ClosestPointTree::ClosestPointTree(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  const int m = static_cast<int>(F.rows());
  faces_.resize(m);
  std::vector<Eigen::Vector3d> centroids(m);
  for (int f = 0; f < m; ++f) {
    Face& face = faces_[f];
    face.a = V.row(F(f, 0)).transpose();
    face.b = V.row(F(f, 1)).transpose();
    face.c = V.row(F(f, 2)).transpose();
    const Eigen::Vector3d ab = face.b - face.a, ac = face.c - face.a;
    // sin^2 of the angle at a below 1e-24: the face is within ~1e-12 edge lengths of a segment,
    // where the plane-projection formula loses all accuracy; its edges give the distance.
    face.flat = ab.cross(ac).squaredNorm() <= 1e-24 * ab.squaredNorm() * ac.squaredNorm();
    centroids[f] = (face.a + face.b + face.c) / 3.0;
  }
  order_.resize(m);
  for (int f = 0; f < m; ++f) order_[f] = f;
  nodes_.reserve(2 * (m / kLeafSize + 1));
  build(0, m, centroids);
}

int ClosestPointTree::build(int begin, int end, const std::vector<Eigen::Vector3d>& centroids) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d box, centre_box;
  for (int i = begin; i < end; ++i) {
    const Face& f = faces_[order_[i]];
    box.extend(f.a).extend(f.b).extend(f.c);
    centre_box.extend(centroids[order_[i]]);
  }
  nodes_[index].box = box;
  if (end - begin <= kLeafSize) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  int axis = 0;
  centre_box.sizes().maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int x, int y) { return centroids[x][axis] < centroids[y][axis]; });
  build(begin, mid, centroids);
  const int right = build(mid, end, centroids);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

// Closest point by Voronoi regions of the triangle (Ericson, Real-Time Collision Detection 5.1.5).
double ClosestPointTree::face_squared_distance(const Face& f, const Eigen::Vector3d& q) const {
  const Eigen::Vector3d &a = f.a, &b = f.b, &c = f.c;
  if (f.flat)
    return std::min({segment_squared_distance(a, b, q), segment_squared_distance(b, c, q),
                     segment_squared_distance(c, a, q)});
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = q - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return ap.squaredNorm();
  const Eigen::Vector3d bp = q - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bp.squaredNorm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (a + (d1 / (d1 - d3)) * ab - q).squaredNorm();
  const Eigen::Vector3d cp = q - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return cp.squaredNorm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (a + (d2 / (d2 - d6)) * ac - q).squaredNorm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return (b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b) - q).squaredNorm();
  const double denom = va + vb + vc;
  if (!(denom > 0))  // rounding on a nearly flat face: fall back to its edges
    return std::min({segment_squared_distance(a, b, q), segment_squared_distance(b, c, q),
                     segment_squared_distance(c, a, q)});
  const double v = vb / denom, w = vc / denom;
  return (a + v * ab + w * ac - q).squaredNorm();
}

double ClosestPointTree::squared_distance(const Eigen::Vector3d& q, double bound2) const {
  double best = bound2;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node.box.squaredExteriorDistance(q) >= best) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i)
        best = std::min(best, face_squared_distance(faces_[order_[i]], q));
      continue;
    }
    const int left = static_cast<int>(&node - nodes_.data()) + 1, right = node.first;
    const double dl = nodes_[left].box.squaredExteriorDistance(q);
    const double dr = nodes_[right].box.squaredExteriorDistance(q);
    // Nearer child on top of the stack, so it is searched first and tightens `best` early.
    if (dl <= dr) {
      if (dr < best) stack[top++] = right;
      if (dl < best) stack[top++] = left;
    } else {
      if (dl < best) stack[top++] = left;
      if (dr < best) stack[top++] = right;
    }
  }
  return best;
}

} // namespace gshell::detail
