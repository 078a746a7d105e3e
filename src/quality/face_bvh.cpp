#include "quality/face_bvh.h"

#include "geometry/power_of_two_unit.h"

#include <gshell/geometry/closest_point.h>

#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace gshell::detail {
namespace {

// Faces per leaf, at most (measured on bunny00 and builtin:sphere:7; pair leaves 4 -> 8 when the
// refit got cheaper: bunny00 frames and bowl steps certified 3% faster, one-off certificates equal).
constexpr int kPairLeafSize = 8;
constexpr int kDistanceLeafSize = 16;

// Spreads the low 21 bits of x to every third bit.
std::uint64_t spread_bits(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

} // namespace

CoverFrame CoverFrame::of_extent(const Eigen::AlignedBox3d& extent) {
  CoverFrame frame;
  if (extent.isEmpty() || !extent.min().allFinite() || !extent.max().allFinite()) return frame;
  const Eigen::Vector3d centre = extent.center();
  if (centre.allFinite()) frame.origin = centre;
  frame.scale = power_of_two_unit(extent.sizes().maxCoeff());
  return frame;
}

template <class Centroid> FaceBvh::Keyed FaceBvh::morton_order(int m, const Centroid& centroid, CoverFrame* frame) {
  // Sort faces along a Morton (Z-order) curve of their centroids: spatial neighbours become
  // slot neighbours, and the code bits give spatial split planes. The extent is a min / max,
  // exact in any order, so reducing it in parallel gives the serial loop's codes.
  const Eigen::AlignedBox3d extent = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, m, 4096), Eigen::AlignedBox3d(),
      [&](const tbb::blocked_range<int>& r, Eigen::AlignedBox3d box) {
        for (int f = r.begin(); f < r.end(); ++f) box.extend(centroid(f));
        return box;
      },
      [](Eigen::AlignedBox3d a, const Eigen::AlignedBox3d& b) { return a.extend(b); });
  if (frame) *frame = CoverFrame::of_extent(extent);
  const Eigen::Vector3d origin = extent.min();
  constexpr double kCells = (1 << 21) - 1;
  const Eigen::Vector3d scale =
      (extent.sizes().array() > 0).select(kCells / extent.sizes().array(), 0.0);
  auto cell = [&](const Eigen::Vector3d& c, int d) {
    const double x = (c[d] - origin[d]) * scale[d];
    return static_cast<std::uint64_t>(x > 0 ? std::min(x, kCells) : 0.0); // NaN (overflow) -> 0
  };
  Keyed keyed(m);
  tbb::parallel_for(tbb::blocked_range<int>(0, m, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int f = r.begin(); f < r.end(); ++f) {
      const Eigen::Vector3d c = centroid(f);
      keyed[f] = {spread_bits(cell(c, 0)) | spread_bits(cell(c, 1)) << 1 |
                      spread_bits(cell(c, 2)) << 2,
                  f};
    }
  });
  tbb::parallel_sort(keyed.begin(), keyed.end());
  return keyed;
}

void FaceBvh::build_nodes(const Keyed& keyed, int leaf_size) {
  const int m = static_cast<int>(keyed.size());
  // Counted first and allocated once: reserving the worst case (2m - 1 nodes, one face per leaf)
  // and shrinking afterwards held 72 bytes per face at the build, about 4x what is used, and
  // the certificate builds its two trees at once where generation peaks.
  nodes_.reserve(static_cast<std::size_t>(count_nodes(keyed, 0, m, leaf_size)));
  build(keyed, 0, m, leaf_size);
}

int FaceBvh::split(const Keyed& keyed, int begin, int end) {
  const std::uint64_t first = keyed[begin].first, last = keyed[end - 1].first;
  if (first == last) return begin + (end - begin) / 2;
  const std::uint64_t bit = std::uint64_t{1} << (63 - std::countl_zero(first ^ last));
  // Codes are sorted and share the bits above `bit`: the ones with `bit` set come last.
  return static_cast<int>(std::partition_point(keyed.begin() + begin, keyed.begin() + end,
                                               [&](const std::pair<std::uint64_t, int>& k) { return !(k.first & bit); }) -
                          keyed.begin());
}

int FaceBvh::count_nodes(const Keyed& keyed, int begin, int end, int leaf_size) {
  if (end - begin <= leaf_size) return 1;
  const int mid = split(keyed, begin, end);
  return 1 + count_nodes(keyed, begin, mid, leaf_size) + count_nodes(keyed, mid, end, leaf_size);
}

FaceBvh::FaceBvh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Use use, const std::optional<CoverFrame>& frame) {
  if (frame) frame_ = *frame;
  const int m = static_cast<int>(F.rows());
  if (m == 0) return;
  auto corner = [&](int f, int k) -> Eigen::Vector3d { return V.row(F(f, k)).transpose(); };
  const Keyed keyed = morton_order(
      m, [&](int f) -> Eigen::Vector3d { return (corner(f, 0) + corner(f, 1) + corner(f, 2)) / 3.0; },
      frame ? nullptr : &frame_);

  slot_face_.resize(m);
  if (use != Use::float_pairs) slot_box_.resize(m);
  slot_float_box_.resize(m);
  const bool distances = use == Use::distances;
  if (distances) slot_triangle_.resize(m);
  tbb::parallel_for(tbb::blocked_range<int>(0, m, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int s = r.begin(); s < r.end(); ++s) {
      const int f = keyed[s].second;
      slot_face_[s] = f;
      set_slot_box(s, face_box(V, F, f));
      if (!distances) continue;
      const Eigen::Vector3d a = corner(f, 0), b = corner(f, 1), c = corner(f, 2);
      slot_triangle_[s] = {a, b, c, triangle_is_flat(a, b, c)};
    }
  });
  build_nodes(keyed, distances ? kDistanceLeafSize : kPairLeafSize);
  if (distances) build_oriented_boxes();
}

void FaceBvh::build_oriented_boxes() {
  const int count = static_cast<int>(nodes_.size());
  node_oriented_box_.resize(count);
  // Area-weighted normals (twice the area), summed up the tree: children come after their parent.
  std::vector<Eigen::Vector3d> normal(count, Eigen::Vector3d::Zero());
  tbb::parallel_for(tbb::blocked_range<int>(0, count, 1024), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i)
      if (nodes_[i].leaf())
        for (int s = nodes_[i].begin; s < nodes_[i].end; ++s) {
          const Triangle& t = slot_triangle_[s];
          normal[i] += (t.b - t.a).cross(t.c - t.a);
        }
  });
  for (int i = count - 1; i >= 0; --i)
    if (!nodes_[i].leaf()) normal[i] = normal[i + 1] + normal[nodes_[i].right];

  // Axes from the node's normal n: the coordinate axis least along n gives the first tangent.
  auto start_box = [&](int i) -> OrientedBox& {
    OrientedBox& box = node_oriented_box_[i];
    const double length = normal[i].norm();
    const Eigen::Vector3d n =
        length > 0 && std::isfinite(length) ? Eigen::Vector3d(normal[i] / length) : Eigen::Vector3d::UnitZ();
    int k;
    n.cwiseAbs().minCoeff(&k);
    const Eigen::Vector3d t = (Eigen::Vector3d::Unit(k) - n[k] * n).normalized();
    box.axes << t.transpose(), n.cross(t).transpose(), n.transpose();
    box.lo.setConstant(std::numeric_limits<double>::infinity());
    box.hi.setConstant(-std::numeric_limits<double>::infinity());
    return box;
  };
  auto extend = [](OrientedBox& box, const Eigen::Vector3d& p) {
    const Eigen::Vector3d x = box.axes * p;
    box.lo = box.lo.cwiseMin(x);
    box.hi = box.hi.cwiseMax(x);
  };
  // Projections and the query's own are rounded; a pad far above that error (relative 1e-12 of
  // the coordinates, plus the same of the extent) keeps every vertex inside.
  auto pad = [](OrientedBox& box) {
    const Eigen::Vector3d e = 1e-12 * (box.lo.cwiseAbs().cwiseMax(box.hi.cwiseAbs()) + (box.hi - box.lo));
    box.lo -= e;
    box.hi += e;
  };
  // Leaves from their triangles' corners; inner nodes from the corners of their children's boxes
  // (bounds of bounds: looser than from the faces, but the leaves are where queries spend).
  tbb::parallel_for(tbb::blocked_range<int>(0, count, 1024), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) {
      if (!nodes_[i].leaf()) continue;
      OrientedBox& box = start_box(i);
      for (int s = nodes_[i].begin; s < nodes_[i].end; ++s)
        for (const Eigen::Vector3d* p : {&slot_triangle_[s].a, &slot_triangle_[s].b, &slot_triangle_[s].c})
          extend(box, *p);
      pad(box);
    }
  });
  for (int i = count - 1; i >= 0; --i) {
    if (nodes_[i].leaf()) continue;
    OrientedBox& box = start_box(i);
    for (int child : {i + 1, nodes_[i].right}) {
      const OrientedBox& c = node_oriented_box_[child];
      for (int corner = 0; corner < 8; ++corner) {
        const Eigen::Vector3d local((corner & 1 ? c.hi : c.lo)[0], (corner & 2 ? c.hi : c.lo)[1],
                                    (corner & 4 ? c.hi : c.lo)[2]);
        extend(box, c.axes.transpose() * local);
      }
    }
    pad(box);
  }
}

double FaceBvh::oriented_squared_distance(int node, const Eigen::Vector3d& q) const {
  const OrientedBox& box = node_oriented_box_[node];
  const Eigen::Vector3d x = box.axes * q;
  return (box.lo - x).cwiseMax(x - box.hi).cwiseMax(0.0).squaredNorm();
}

FaceBvh::FaceBvh(const std::vector<Eigen::AlignedBox3d>& boxes, int leaf_size,
                 const std::optional<CoverFrame>& frame) {
  if (frame) frame_ = *frame;
  const int m = static_cast<int>(boxes.size());
  if (m == 0) return;
  const Keyed keyed =
      morton_order(m, [&](int f) -> Eigen::Vector3d { return boxes[f].center(); }, frame ? nullptr : &frame_);
  slot_face_.resize(m);
  slot_box_.resize(m);
  slot_float_box_.resize(m);
  for (int s = 0; s < m; ++s) {
    slot_face_[s] = keyed[s].second;
    set_slot_box(s, boxes[keyed[s].second]);
  }
  build_nodes(keyed, std::max(leaf_size, 1));
}

Eigen::AlignedBox3d FaceBvh::face_box(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f) {
  Eigen::AlignedBox3d box(V.row(F(f, 0)).transpose());
  box.extend(V.row(F(f, 1)).transpose()).extend(V.row(F(f, 2)).transpose());
  return box;
}

bool FaceBvh::some_face_box_meets(const Eigen::AlignedBox3d& box) const {
  if (nodes_.empty()) return false;
  FloatBox b;
  for (int d = 0; d < 3; ++d) {
    b.lo[d] = float_lower_end(box.min()[d], frame_.origin[d], frame_.scale);
    b.hi[d] = float_upper_end(box.max()[d], frame_.origin[d], frame_.scale);
  }
  // Depth first, one pending right child per level of the path. A path splits at most 64 times
  // by a bit of the 64-bit codes and 31 times by halving equal codes, so the stack never fills;
  // if it did, the answer would only be a conservative true.
  constexpr int kStack = 128;
  int stack[kStack];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const int i = stack[--top];
    const Node& node = nodes_[i];
    if (!(node.lo[0] <= b.hi[0] && b.lo[0] <= node.hi[0] && node.lo[1] <= b.hi[1] && b.lo[1] <= node.hi[1] &&
          node.lo[2] <= b.hi[2] && b.lo[2] <= node.hi[2]))
      continue;
    if (!node.leaf()) {
      if (top + 2 > kStack) return true;
      stack[top++] = node.right;
      stack[top++] = i + 1; // the left child
      continue;
    }
    for (int s = node.begin; s < node.end; ++s)
      if (float_boxes_meet(slot_float_box_[s], b)) return true;
  }
  return false;
}

void FaceBvh::set_float_box(int slot, const Eigen::AlignedBox3d& box) {
  // The differences are rounded to doubles (relative error 2^-53) before the float covers move
  // them out by 2^-22 of themselves: still covers of the exact differences.
  for (int d = 0; d < 3; ++d) {
    slot_float_box_[slot].lo[d] = float_lower_end(box.min()[d], frame_.origin[d], frame_.scale);
    slot_float_box_[slot].hi[d] = float_upper_end(box.max()[d], frame_.origin[d], frame_.scale);
  }
}

void FaceBvh::check_same_frame(const FaceBvh& other) const {
  if (frame_ != other.frame_ && !nodes_.empty() && !other.nodes_.empty())
    throw std::logic_error("FaceBvh: two trees searched together measure their float boxes in different frames");
}

void FaceBvh::set_leaf_box(Node& node) const {
  // The float cover of the slots' exact boxes: rounding each end outwards, then taking the
  // min / max, is the same as rounding the exact min / max outwards (rounding is monotone).
  for (int d = 0; d < 3; ++d) {
    node.lo[d] = std::numeric_limits<float>::infinity();
    node.hi[d] = -std::numeric_limits<float>::infinity();
  }
  for (int s = node.begin; s < node.end; ++s)
    for (int d = 0; d < 3; ++d) {
      node.lo[d] = std::min(node.lo[d], slot_float_box_[s].lo[d]);
      node.hi[d] = std::max(node.hi[d], slot_float_box_[s].hi[d]);
    }
}

void FaceBvh::refit_nodes() {
  assert(slot_triangle_.empty() && "FaceBvh::refit_nodes needs Use::pairs");
  const int count = static_cast<int>(nodes_.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, count, 8192), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i)
      if (nodes_[i].leaf()) set_leaf_box(nodes_[i]);
  });
  // Children come after their parent (depth-first), so a backward pass sees them first.
  for (int i = count - 1; i >= 0; --i)
    if (!nodes_[i].leaf()) merge_child_boxes(i);
}

void FaceBvh::refit_nodes_over(const std::vector<int>& sorted_slots) {
  assert(slot_triangle_.empty() && "FaceBvh::refit_nodes_over needs Use::pairs");
  assert(std::is_sorted(sorted_slots.begin(), sorted_slots.end()));
  if (!nodes_.empty() && !sorted_slots.empty())
    refit_subtree(0, sorted_slots.data(), sorted_slots.data() + sorted_slots.size());
}

// [first, last): the sorted slots under node i that moved, not empty.
void FaceBvh::refit_subtree(int i, const int* first, const int* last) {
  Node& n = nodes_[i];
  if (n.leaf()) {
    set_leaf_box(n);
    return;
  }
  const int* mid = std::lower_bound(first, last, nodes_[i + 1].end); // the left child's slots end there
  if (first != mid) refit_subtree(i + 1, first, mid);
  if (mid != last) refit_subtree(n.right, mid, last);
  merge_child_boxes(i);
}

void FaceBvh::merge_child_boxes(int i) {
  Node& n = nodes_[i];
  const Node &l = nodes_[i + 1], &r = nodes_[n.right];
  for (int d = 0; d < 3; ++d) {
    n.lo[d] = std::min(l.lo[d], r.lo[d]);
    n.hi[d] = std::max(l.hi[d], r.hi[d]);
  }
}

// Splits a slot range where its Morton codes first differ (an octree-like spatial split, so
// every node covers one compact region); equal codes are split in the middle.
int FaceBvh::build(const Keyed& keyed, int begin, int end, int leaf_size) {
  const int node = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  nodes_[node].begin = begin;
  nodes_[node].end = end;
  if (end - begin <= leaf_size) {
    set_leaf_box(nodes_[node]);
    return node;
  }
  const int mid = split(keyed, begin, end);
  build(keyed, begin, mid, leaf_size);
  const int right = build(keyed, mid, end, leaf_size);
  nodes_[node].right = right;
  merge_child_boxes(node);
  return node;
}

double FaceBvh::node_squared_distance(const Node& n, const Eigen::Vector3d& q) {
  double d2 = 0;
  for (int d = 0; d < 3; ++d) {
    const double below = n.lo[d] - q[d], above = q[d] - n.hi[d];
    const double gap = std::max({below, above, 0.0});
    d2 += gap * gap;
  }
  return d2;
}

double FaceBvh::face_squared_distance(const Triangle& t, const Eigen::Vector3d& q) {
  return (closest_point_on_triangle(q, t.a, t.b, t.c, t.flat) - q).squaredNorm();
}

double FaceBvh::squared_distance(const Eigen::Vector3d& q, double bound2) const {
  return squared_distance(q, bound2, [](int) { return true; });
}

} // namespace gshell::detail
