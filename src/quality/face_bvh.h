#pragma once
// Bounding-volume hierarchy over the faces of a triangle mesh, for the quality measures:
// - all pairs of faces whose boxes meet (within one mesh or between two), the candidates of the
//   intersection counts, by a parallel simultaneous descent of both trees;
// - closest-point distance queries (thickness).
// Built once (faces sorted along a Morton curve, split where the codes differ); queries are
// const and may run from many threads.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <tbb/parallel_invoke.h>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace gshell::detail {

// A float no larger (float_at_most) / no smaller (float_at_least) than x, without branches: these
// run for six coordinates of every face of every frame, and a rounding that tested its result
// against x mispredicted half the time. x is moved outwards by 2^-22 of itself (more than half a
// float ulp at x, so rounding to nearest cannot come back past x) and by the least denormal float
// (for x near 0), then rounded; beyond the float range, the largest float of the right sign or an
// infinity. At most two ulps looser than the tightest float, and monotone in x.
inline float float_at_most(double x) {
  const double moved = x - std::abs(x) * 0x1p-22 - 0x1p-149;
  return std::min(static_cast<float>(moved), std::numeric_limits<float>::max());
}

inline float float_at_least(double x) { return -float_at_most(-x); }

/// Where and in what unit float covers measure a point x: at (x - origin) * scale. An origin near
/// the boxes keeps covers as tight far from the model's own origin as near it (FaceBvh's
/// constructor says why). The scale, a power of two (so multiplying by it is exact), brings the
/// model's extent to about 1, inside the range where floats keep their 24 bits: a model 1e39
/// across (coordinates up to 1e50 are accepted) had every cover clamped to the largest float,
/// every pair of faces met, and the guard's contact search went quadratic (dino scaled by 1e39:
/// 3 s per repair iteration against 0.06 s at unit scale); a tiny one would fall below the
/// normal floats.
struct CoverFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double scale = 1;
  /// The centre of `extent`, and the power of two that brings its largest side into [0.5, 1);
  /// origin 0 and scale 1 for an empty or non-finite extent or one of zero size.
  static CoverFrame of_extent(const Eigen::AlignedBox3d& extent);
  bool operator==(const CoverFrame& other) const { return origin == other.origin && scale == other.scale; }
  bool operator!=(const CoverFrame& other) const { return !(*this == other); }
};

// The float cover's ends of a box's end in a frame (along one axis): as above, and unbounded where
// the measure is not a finite double (it overflowed, or the box was not finite), so a cover never
// misses what it should hold.
inline float float_lower_end(double lo, double origin, double scale) {
  const double x = (lo - origin) * scale;
  return std::abs(x) <= std::numeric_limits<double>::max() ? float_at_most(x) : -std::numeric_limits<float>::infinity();
}
inline float float_upper_end(double hi, double origin, double scale) {
  const double x = (hi - origin) * scale;
  return std::abs(x) <= std::numeric_limits<double>::max() ? float_at_least(x) : std::numeric_limits<float>::infinity();
}

inline bool exact_boxes_meet(const Eigen::AlignedBox3d& a, const Eigen::AlignedBox3d& b) {
  return (a.min().array() <= b.max().array()).all() && (b.min().array() <= a.max().array()).all();
}

class FaceBvh {
public:
  /// What the tree is built for: pair searches want small leaves (few box pairs per leaf pair),
  /// distance queries bigger ones (fewer nodes; faces in a leaf are cheap to reject by box) and
  /// a copy of the triangles in leaf order. `float_pairs`: pair searches whose caller decides
  /// every visited pair exactly anyway (for_each_pair_of_meeting_float_boxes only): the faces'
  /// exact boxes are not kept, only their float covers (24 bytes per face instead of 72; at
  /// millions of faces the certificate's two trees held 0.5 GB of exact boxes).
  enum class Use { pairs, distances, float_pairs };

  /// F must index rows of V (checked by the caller).
  ///
  /// `frame`: how the float covers of the boxes are measured (CoverFrame); by default the frame of
  /// the extent of the faces' centroids. A float has 24 bits, so covers measured from the model's
  /// own origin are as coarse as the coordinates are large: a scan 1 unit across placed 4e6 away
  /// (survey coordinates) had covers about 0.5 wide, every face's box met every other's, and a
  /// certificate of bunny00 took 20 times as long. Two trees searched together (the pair
  /// searches over `other`) must share their frame: give both the same one.
  FaceBvh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Use use,
          const std::optional<CoverFrame>& frame = std::nullopt);

  /// A tree for pair searches (Use::pairs) over given boxes, one per face: faces swept along a
  /// motion, or grown by a search radius (contact candidates). Slot boxes are these boxes. Leaves
  /// hold at most leaf_size faces.
  explicit FaceBvh(const std::vector<Eigen::AlignedBox3d>& boxes, int leaf_size = 4,
                   const std::optional<CoverFrame>& frame = std::nullopt);

  /// How the float covers are measured (see the constructor).
  const CoverFrame& frame() const { return frame_; }

  int num_faces() const { return static_cast<int>(slot_face_.size()); }

  /// Moving the faces (Use::pairs or float_pairs), in two parts so that callers set the new face boxes in a pass
  /// over the faces of their own: set_slot_box for every slot (from several threads, each slot
  /// once), then refit_nodes. Face and node boxes are then what a build computes, the tree's
  /// shape and leaf order are kept. Every query stays exact (a node's box still holds its faces'
  /// boxes); only its speed depends on how compact the nodes stay, which they do when the faces
  /// follow a motion that keeps neighbouring faces near each other (frames of a deformation).
  void set_slot_box(int slot, const Eigen::AlignedBox3d& box) {
    if (!slot_box_.empty()) slot_box_[slot] = box;
    set_float_box(slot, box);
  }
  void refit_nodes();
  /// refit_nodes after set_slot_box for the given slots alone (sorted, each once): only the nodes
  /// above them are refit, O(k log faces) for k slots where refit_nodes passes over every node.
  void refit_nodes_over(const std::vector<int>& sorted_slots);

  /// Face ids in the tree's leaf order: consecutive faces are close in space, so work done in
  /// this order stays cache-friendly.
  const std::vector<int>& faces_in_leaf_order() const { return slot_face_; }

  /// Calls visit(s, t) once for every unordered pair of distinct faces whose closed boxes meet,
  /// with s, t their slots (positions in faces_in_leaf_order(), in any order): data the caller
  /// keeps in slot order is read with good locality. Face boxes are the exact min/max of the
  /// vertex doubles, so no touching pair is missed. visit runs concurrently from several threads.
  /// Not for Use::float_pairs trees (they keep no exact boxes).
  template <class Visit> void for_each_overlapping_pair(Visit&& visit) const;

  /// Calls visit(s, t) for every slot s of this tree and t of `other` whose faces' closed boxes
  /// meet. visit runs concurrently from several threads.
  template <class Visit>
  void for_each_overlapping_pair(const FaceBvh& other, Visit&& visit) const;

  /// The same two searches by the float covers of the slot boxes alone (rounded outwards, so they
  /// hold the exact boxes): every pair whose exact boxes meet is visited, and a few more whose
  /// boxes only come within float rounding. For callers whose pair test is exact anyway (and
  /// cheaper than the double box test for most pairs, e.g. neighbours settled by their ids): no
  /// second test of 48-byte boxes per pair.
  template <class Visit> void for_each_pair_of_meeting_float_boxes(Visit&& visit) const;
  template <class Visit> void for_each_pair_of_meeting_float_boxes(const FaceBvh& other, Visit&& visit) const;

  /// Calls visit(b0, e0, b1, e1) for every unordered pair of leaves whose boxes meet, each leaf
  /// with itself included (then b0 == b1): the slot ranges [b0, e0), [b1, e1) of their faces.
  /// A leaf's box holds its faces' boxes (rounded outwards), so every pair of faces whose boxes
  /// meet lies in one visited pair of leaves; the caller tests what it needs within them.
  /// visit runs concurrently from several threads.
  template <class Visit> void for_each_overlapping_leaf_pair(Visit&& visit) const;

  /// Calls visit(b0, e0, b1, e1) for every leaf [b0, e0) of this tree and [b1, e1) of `other`
  /// whose boxes meet. visit runs concurrently from several threads.
  template <class Visit> void for_each_overlapping_leaf_pair(const FaceBvh& other, Visit&& visit) const;

  /// Whether some face's box meets `box` (closed boxes), by the float covers of the boxes: true
  /// also for a few boxes that only come within float rounding of a face's, never false for one
  /// that meets. An empty tree meets nothing.
  bool some_face_box_meets(const Eigen::AlignedBox3d& box) const;

  /// Squared distance from q to the surface (model units squared), or bound2 if that is smaller.
  /// Needs Use::distances.
  /// A good bound2 (e.g. the squared distance to a known point of the surface) prunes the search.
  double squared_distance(const Eigen::Vector3d& q, double bound2) const;
  /// The same over the faces f for which counts(f) is true (asked only of faces within the bound);
  /// `nearest` (if not null) gets the face at that distance (unchanged when none is nearer than bound2).
  template <class Counts>
  double squared_distance(const Eigen::Vector3d& q, double bound2, Counts&& counts, int* nearest = nullptr) const;

private:
  // Node boxes are floats rounded outwards (conservative, half the memory of doubles).
  struct Node {
    float lo[3], hi[3];
    int begin = 0, end = 0; // slots of the faces under this node
    int right = 0;          // inner node: index of the right child (the left one is next)
    bool leaf() const { return right == 0; }
  };
  struct Triangle {
    Eigen::Vector3d a, b, c;
    bool flat = false; // triangle_is_flat (geometry/closest_point.h), decided once per face
  };

  using Keyed = std::vector<std::pair<std::uint64_t, int>>; // (Morton code, face), sorted
  /// (Morton code, face) of faces 0..m-1 by their centroids centroid(f), sorted along the curve.
  /// The centroids are made where they are needed, twice, rather than held (24 bytes per face of
  /// fresh memory at every tree build).
  /// `frame` (if given): the frame of the centroids' extent.
  template <class Centroid> static Keyed morton_order(int m, const Centroid& centroid, CoverFrame* frame = nullptr);
  void build_nodes(const Keyed& keyed, int leaf_size);
  int build(const Keyed& keyed, int begin, int end, int leaf_size);
  // Where build splits slots [begin, end) (sorted codes), and how many nodes it makes there.
  static int split(const Keyed& keyed, int begin, int end);
  static int count_nodes(const Keyed& keyed, int begin, int end, int leaf_size);
  static double face_squared_distance(const Triangle& t, const Eigen::Vector3d& q);
  static bool nodes_meet(const Node& a, const Node& b);
  static Eigen::AlignedBox3d face_box(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f);
  // Node boxes from the slot boxes below them, rounded outwards to floats.
  void set_leaf_box(Node& node) const;
  // Inner node i's box from its two children's.
  void merge_child_boxes(int i);
  void refit_subtree(int i, const int* first, const int* last);
  // Squared distance (in the frame's units) from q, measured in the frame, to the node's cover.
  static double node_squared_distance(const Node& n, const Eigen::Vector3d& q);

  // Use::distances: every node also has a box in a frame of its own, its third axis the node's
  // area-weighted face normal. Queries from just off a gently curved surface (a shell's top over
  // its base) sit at about the same distance from every node near their foot point; the axis-
  // aligned boxes of those nodes stick out towards the query by up to their width, so a search
  // opened about sqrt(distance / width) of them per level (it grew 1.6x per refinement at a
  // fixed thickness). A box along the normal is as thin as the surface's bend over the node.
  struct OrientedBox {
    Eigen::Matrix3d axes;   // unit rows: a tangent, the other tangent, the normal
    Eigen::Vector3d lo, hi; // the node's vertices' coordinates along the axes, padded outwards
  };
  void build_oriented_boxes();
  double oriented_squared_distance(int node, const Eigen::Vector3d& q) const;
  // A distance query's point in model units and in the covers' frame, and the factor that takes
  // squared distances in the frame back to model units (exact: the square of a power of two).
  struct Query {
    Eigen::Vector3d q, in_frame;
    double to_model;
  };
  Query query(const Eigen::Vector3d& q) const {
    const double unit = 1 / frame_.scale;
    return {q, (q - frame_.origin) * frame_.scale, unit * unit};
  }
  // The larger of the two boxes' lower bounds on the squared distance from q to the node's faces.
  double node_lower_bound(int node, const Query& q) const {
    return std::max(node_squared_distance(nodes_[node], q.in_frame) * q.to_model, oriented_squared_distance(node, q.q));
  }

  // Simultaneous descent of two trees (or one with itself); leaves(na, nb, self) at every pair of
  // leaves whose boxes meet, self when both are the same leaf of one tree.
  template <class Leaves>
  void join(int a, const FaceBvh& other, int b, bool same_tree, Leaves& leaves) const;

  // A slot's box in floats rounded outwards: holds the exact box, so a pair whose float boxes miss
  // each other has exact boxes that miss too. Leaf pairs test these first (half the bytes, no
  // Eigen temporaries, one branch), and the exact boxes only when they meet.
  struct FloatBox {
    float lo[3], hi[3];
  };
  static bool float_boxes_meet(const FloatBox& a, const FloatBox& b) {
    return (a.lo[0] <= b.hi[0]) & (b.lo[0] <= a.hi[0]) & (a.lo[1] <= b.hi[1]) & (b.lo[1] <= a.hi[1]) &
           (a.lo[2] <= b.hi[2]) & (b.lo[2] <= a.hi[2]);
  }
  bool slot_boxes_meet(int i, const FaceBvh& other, int j) const {
    return float_boxes_meet(slot_float_box_[i], other.slot_float_box_[j]) &&
           exact_boxes_meet(slot_box_[i], other.slot_box_[j]);
  }
  // slot_float_box_[slot]: the float cover of `box` in frame_.
  void set_float_box(int slot, const Eigen::AlignedBox3d& box);
  // Pair searches over two trees compare covers measured in one frame.
  void check_same_frame(const FaceBvh& other) const;

  // Per slot (leaf order): face id, exact box, its float cover, triangle.
  std::vector<int> slot_face_;
  std::vector<Eigen::AlignedBox3d> slot_box_; // empty for Use::float_pairs
  std::vector<FloatBox> slot_float_box_;
  std::vector<Triangle> slot_triangle_; // Use::distances only
  std::vector<OrientedBox> node_oriented_box_; // Use::distances only, one per node
  std::vector<Node> nodes_; // depth-first, root first
  CoverFrame frame_; // of the float covers (slots' and nodes')
};

// ---- templates ------------------------------------------------------------------------------

inline bool FaceBvh::nodes_meet(const Node& a, const Node& b) {
  return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
         a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
}

template <class Leaves>
void FaceBvh::join(int a, const FaceBvh& other, int b, bool same_tree, Leaves& leaves) const {
  // Node pairs over fewer faces are joined by one thread: a task costs about a microsecond.
  constexpr int kParallelFaces = 2048;
  const Node& na = nodes_[a];
  const Node& nb = other.nodes_[b];
  if (!nodes_meet(na, nb)) return;
  auto run = [&](auto&&... jobs) {
    if ((na.end - na.begin) + (nb.end - nb.begin) > kParallelFaces) tbb::parallel_invoke(jobs...);
    else (jobs(), ...);
  };
  if (same_tree && a == b) { // pairs within one subtree
    if (na.leaf()) {
      leaves(na, na, true);
      return;
    }
    const int l = a + 1, r = na.right;
    run([&] { join(l, other, l, true, leaves); },
        [&] { join(r, other, r, true, leaves); },
        [&] { join(l, other, r, true, leaves); });
    return;
  }
  if (na.leaf() && nb.leaf()) {
    leaves(na, nb, false);
    return;
  }
  // Descend the node with more faces (a leaf cannot be split).
  if (nb.leaf() || (!na.leaf() && na.end - na.begin >= nb.end - nb.begin)) {
    run([&] { join(a + 1, other, b, same_tree, leaves); },
        [&] { join(na.right, other, b, same_tree, leaves); });
  } else {
    run([&] { join(a, other, b + 1, same_tree, leaves); },
        [&] { join(a, other, nb.right, same_tree, leaves); });
  }
}

template <class Visit>
void FaceBvh::for_each_overlapping_pair(Visit&& visit) const {
  assert(slot_box_.size() == slot_face_.size() && "for_each_overlapping_pair needs exact boxes (not Use::float_pairs)");
  auto leaves = [&](const Node& na, const Node& nb, bool self) {
    for (int i = na.begin; i < na.end; ++i)
      for (int j = self ? i + 1 : nb.begin; j < nb.end; ++j)
        if (slot_boxes_meet(i, *this, j)) visit(i, j);
  };
  if (!nodes_.empty()) join(0, *this, 0, true, leaves);
}

template <class Visit>
void FaceBvh::for_each_overlapping_pair(const FaceBvh& other, Visit&& visit) const {
  assert(slot_box_.size() == slot_face_.size() && other.slot_box_.size() == other.slot_face_.size() &&
         "for_each_overlapping_pair needs exact boxes (not Use::float_pairs)");
  auto leaves = [&](const Node& na, const Node& nb, bool) {
    for (int i = na.begin; i < na.end; ++i)
      for (int j = nb.begin; j < nb.end; ++j)
        if (slot_boxes_meet(i, other, j)) visit(i, j);
  };
  check_same_frame(other);
  if (!nodes_.empty() && !other.nodes_.empty()) join(0, other, 0, false, leaves);
}

template <class Visit>
void FaceBvh::for_each_pair_of_meeting_float_boxes(Visit&& visit) const {
  auto leaves = [&](const Node& na, const Node& nb, bool self) {
    const FloatBox* box = slot_float_box_.data();
    for (int i = na.begin; i < na.end; ++i) {
      const FloatBox a = box[i];
      for (int j = self ? i + 1 : nb.begin; j < nb.end; ++j)
        if (float_boxes_meet(a, box[j])) visit(i, j);
    }
  };
  if (!nodes_.empty()) join(0, *this, 0, true, leaves);
}

template <class Visit>
void FaceBvh::for_each_pair_of_meeting_float_boxes(const FaceBvh& other, Visit&& visit) const {
  auto leaves = [&](const Node& na, const Node& nb, bool) {
    const FloatBox *box = slot_float_box_.data(), *other_box = other.slot_float_box_.data();
    for (int i = na.begin; i < na.end; ++i) {
      const FloatBox a = box[i];
      for (int j = nb.begin; j < nb.end; ++j)
        if (float_boxes_meet(a, other_box[j])) visit(i, j);
    }
  };
  check_same_frame(other);
  if (!nodes_.empty() && !other.nodes_.empty()) join(0, other, 0, false, leaves);
}

template <class Visit>
void FaceBvh::for_each_overlapping_leaf_pair(Visit&& visit) const {
  auto leaves = [&](const Node& na, const Node& nb, bool) { visit(na.begin, na.end, nb.begin, nb.end); };
  if (!nodes_.empty()) join(0, *this, 0, true, leaves);
}

template <class Visit>
void FaceBvh::for_each_overlapping_leaf_pair(const FaceBvh& other, Visit&& visit) const {
  auto leaves = [&](const Node& na, const Node& nb, bool) { visit(na.begin, na.end, nb.begin, nb.end); };
  check_same_frame(other);
  if (!nodes_.empty() && !other.nodes_.empty()) join(0, other, 0, false, leaves);
}

template <class Counts>
double FaceBvh::squared_distance(const Eigen::Vector3d& q, double bound2, Counts&& counts, int* nearest) const {
  assert(slot_triangle_.size() == slot_face_.size() && "FaceBvh built without Use::distances");
  double best = bound2;
  if (nodes_.empty()) return best;
  struct Entry {
    int node;
    double d2; // lower bound on the squared distance from q to the node's faces
  };
  Entry stack[128]; // holds at most depth + 1 entries; depth <= 63 code bits + log2(faces)
  int top = 0;
  const Query at = query(q);
  stack[top++] = {0, node_lower_bound(0, at)};
  while (top > 0) {
    const Entry e = stack[--top];
    if (e.d2 >= best) continue;
    const Node& node = nodes_[e.node];
    if (node.leaf()) {
      for (int s = node.begin; s < node.end; ++s)
        if (slot_box_[s].squaredExteriorDistance(q) < best && counts(slot_face_[s]))
          if (const double d2 = face_squared_distance(slot_triangle_[s], q); d2 < best) {
            best = d2;
            if (nearest) *nearest = slot_face_[s];
          }
      continue;
    }
    const Entry l{e.node + 1, node_lower_bound(e.node + 1, at)};
    const Entry r{node.right, node_lower_bound(node.right, at)};
    // The nearer child goes on top of the stack: searched first, it tightens `best` early.
    const Entry& near = l.d2 <= r.d2 ? l : r;
    const Entry& far = l.d2 <= r.d2 ? r : l;
    if (far.d2 < best) stack[top++] = far;
    if (near.d2 < best) stack[top++] = near;
  }
  return best;
}

} // namespace gshell::detail
