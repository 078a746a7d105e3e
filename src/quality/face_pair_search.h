#pragma once
// Exact pair searches over the faces of one or two meshes: the bounding-volume hierarchy finds
// the pairs whose boxes meet, an exact test (exact_faces.h) decides each, in parallel.
#include "geometry/item_groups.h"
#include "quality/exact_faces.h"
#include "quality/face_bvh.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

namespace gshell::detail {

using FacePairs = std::vector<std::pair<int, int>>;

/// The faces of (V, F) in the slot order of `bvh`, so that pair tests read them with locality.
inline std::vector<ExactFace> exact_faces_in_slot_order(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                                        const FaceBvh& bvh) {
  std::vector<ExactFace> faces(bvh.num_faces());
  const std::vector<int>& face = bvh.faces_in_leaf_order();
  tbb::parallel_for(tbb::blocked_range<int>(0, bvh.num_faces(), 4096), [&](const auto& r) {
    for (int s = r.begin(); s < r.end(); ++s) faces[s] = exact_face(V, F, face[s]);
  });
  return faces;
}

/// Collects pairs found concurrently (one list per thread), then merges and sorts them.
class PairCollector {
public:
  void add(int f, int g) { found_.local().emplace_back(f, g); }
  FacePairs sorted() {
    FacePairs all;
    for (const FacePairs& part : found_) all.insert(all.end(), part.begin(), part.end());
    std::sort(all.begin(), all.end());
    return all;
  }

private:
  tbb::enumerable_thread_specific<FacePairs> found_;
};

/// Faces of one mesh over a set of vertex ids, with their tree and exact shapes, for pair tests
/// that respect shared ids (faces of two sets may share ids too, e.g. a shell's top and walls).
/// F must index rows of V, each face with three distinct ids (checked by the caller).
/// `embedded_star`: null, or one flag per row of V (embedded_stars.h, computed on a surface that
/// contains these faces), kept by reference: pairs sharing a flagged vertex are not tested.
/// `frame`: of the tree's float boxes (FaceBvh), by default the frame of all of V's rows, so that
/// sets over rows of one V are searched together; a set made later over another V takes the
/// frame() of the set it will be searched with.
class FaceSet {
public:
  FaceSet(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const std::vector<char>* embedded_star = nullptr,
          const std::optional<CoverFrame>& frame = std::nullopt)
      : bvh_(V, F, FaceBvh::Use::float_pairs, frame ? *frame : frame_of_rows(V)) {
    take_positions(V, F, embedded_star);
  }

  const CoverFrame& frame() const { return bvh_.frame(); }

  /// The same faces (F as constructed) at new positions V, with new star flags: the tree is refit
  /// (FaceBvh::set_slot_box, refit_nodes), not rebuilt, so a sequence of frames of one motion costs
  /// less per frame.
  void move_to(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const std::vector<char>* embedded_star = nullptr) {
    take_positions(V, F, embedded_star);
    bvh_.refit_nodes();
  }

  /// The same faces after the vertices `vertices` (rows of V; repeats allowed) moved to their rows
  /// of V, every other vertex where the last construction or move put it: only the faces around
  /// them get new shapes and boxes and only the tree nodes above those faces are refit, so moving
  /// k vertices costs about k log(faces) where move_to passes over every face. The star flags
  /// stay those of the last construction or move_to.
  void move_vertices(const Eigen::MatrixXd& V, const std::vector<int>& vertices) {
    if (slots_of_point_.start.empty()) index_points_by_vertex(static_cast<int>(V.rows()));
    std::vector<int> moved_points;
    for (int v : vertices) {
      const int l = v < static_cast<int>(point_of_vertex_.size()) ? point_of_vertex_[v] : -1;
      if (l < 0) continue; // no face of this set uses v
      points_[l] = ExactPoint(V(v, 0), V(v, 1), V(v, 2));
      moved_points.push_back(l);
    }
    const std::vector<int> slots = slots_of_point_.items_of(moved_points);
    double largest = 0;
    for (int s : slots) largest = std::max(largest, place_slot(s));
    // The margin only has to cover the largest coordinate; one that covers a larger one than is
    // left after the move costs a few exact tests, never a wrong answer.
    margin_ = std::max(margin_, slab_margin(largest));
    bvh_.refit_nodes_over(slots);
  }

  /// Drops the star flags (every pair is then decided by the exact test), so that the set can
  /// outlive the flags and follow moves (move_vertices) that would make them stale.
  void forget_stars() {
    star_ = nullptr;
    for (Ids& ids : ids_) ids.stars_embedded = 0;
  }

  /// Calls found(f, g), f < g faces of this set, concurrently for every pair that meets beyond
  /// the vertices and edges it shares (faces_intersect_beyond_shared).
  template <class Found> void for_each_pair_meeting_beyond_shared(Found&& found) const {
    const std::vector<int>& face = bvh_.faces_in_leaf_order();
    bvh_.for_each_pair_of_meeting_float_boxes([&](int s, int t) {
      if (meet(*this, s, *this, t)) found(std::min(face[s], face[t]), std::max(face[s], face[t]));
    });
  }

  /// The same for pairs (f, g), f a face of this set and g one of `other` (over the same ids).
  template <class Found> void for_each_pair_meeting_beyond_shared(const FaceSet& other, Found&& found) const {
    const std::vector<int>&face = bvh_.faces_in_leaf_order(), &other_face = other.bvh_.faces_in_leaf_order();
    bvh_.for_each_pair_of_meeting_float_boxes(other.bvh_, [&](int s, int t) {
      if (meet(*this, s, other, t)) found(face[s], other_face[t]);
    });
  }

private:
  static CoverFrame frame_of_rows(const Eigen::MatrixXd& V) {
    if (V.rows() == 0) return {};
    return CoverFrame::of_extent(
        Eigen::AlignedBox3d(V.colwise().minCoeff().transpose(), V.colwise().maxCoeff().transpose()));
  }

  // Ids are kept apart from the shapes: most pairs of a fine surface are neighbours settled by
  // their ids and stars, and 12 bytes per face stay in cache where 100 would not.
  static bool meet(const FaceSet& a, int s, const FaceSet& b, int t) {
    const Ids &ia = a.ids_[s], &ib = b.ids_[t];
    if ((ia.stars_embedded || ib.stars_embedded) && share_id(ia.id, ib.id)) return false; // in an embedded star
    const SharedCorners shared = shared_corners(ia.id, ib.id);
    if (a.star_ && (shared.count == 1 || shared.count == 2))
      for (int i = 0; i < shared.count; ++i)
        if (a.star_[ia.id[shared.in_a[i]]]) return false;
    const ExactFace fa = a.face_at(s), fb = b.face_at(t);
    // The slabs are made here rather than stored: two cross products cost no more than reading
    // 80 bytes per pair, and at millions of faces storing them was 0.4 GB of fresh memory.
    if (shared.count == 0 && slabs_separate(fa, face_slab(fa), fb, face_slab(fb), std::max(a.margin_, b.margin_)))
      return false;
    return faces_intersect_beyond_shared(fa, fb, shared);
  }

  ExactFace face_at(int s) const {
    ExactFace f;
    f.id = ids_[s].id;
    const Shape& shape = shapes_[s];
    for (int k = 0; k < 3; ++k) f.p[k] = points_[shape.corner[k]];
    f.dim = shape.dim;
    f.end = shape.end;
    return f;
  }

  // The faces' exact shapes at V and their boxes in the tree (one pass over the faces; after a
  // build the boxes are those the build set, so only a refit needs them). The corners are kept
  // once per vertex, in the order the slots first use them, so that faces near in the tree read
  // points near in memory: 24 bytes per vertex and 16 per face where whole faces took 88.
  void take_positions(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const std::vector<char>* embedded_star) {
    const int count = bvh_.num_faces();
    const std::vector<int>& face = bvh_.faces_in_leaf_order();
    if (static_cast<int>(shapes_.size()) != count) {
      shapes_.resize(count);
      ids_.resize(count);
      std::vector<int> local(V.rows(), -1);
      point_id_.clear();
      for (int s = 0; s < count; ++s)
        for (int k = 0; k < 3; ++k) {
          int& l = local[F(face[s], k)];
          if (l < 0) {
            l = static_cast<int>(point_id_.size());
            point_id_.push_back(F(face[s], k));
          }
          shapes_[s].corner[k] = l;
          ids_[s].id[k] = F(face[s], k);
        }
      point_id_.shrink_to_fit();
      points_.resize(point_id_.size());
    }
    const int num_points = static_cast<int>(points_.size());
    tbb::parallel_for(tbb::blocked_range<int>(0, num_points, 4096), [&](const tbb::blocked_range<int>& r) {
      for (int l = r.begin(); l < r.end(); ++l) {
        const int v = point_id_[l];
        points_[l] = ExactPoint(V(v, 0), V(v, 1), V(v, 2));
      }
    });
    star_ = embedded_star ? embedded_star->data() : nullptr;
    const double max_abs = tbb::parallel_reduce(
        tbb::blocked_range<int>(0, count, 4096), 0.0,
        [&](const tbb::blocked_range<int>& r, double largest) {
          for (int s = r.begin(); s < r.end(); ++s) {
            const std::array<int, 3>& id = ids_[s].id;
            ids_[s].stars_embedded = star_ && star_[id[0]] && star_[id[1]] && star_[id[2]];
            largest = std::max(largest, place_slot(s));
          }
          return largest;
        },
        [](double a, double b) { return std::max(a, b); });
    margin_ = slab_margin(max_abs);
  }

  // Slot s's exact shape and tree box from points_; returns its largest coordinate magnitude.
  double place_slot(int s) {
    Shape& shape = shapes_[s];
    const std::array<ExactPoint, 3> p{points_[shape.corner[0]], points_[shape.corner[1]], points_[shape.corner[2]]};
    const ExactFace f = exact_face(ids_[s].id, p);
    shape.dim = f.dim;
    shape.end = f.end;
    Eigen::AlignedBox3d box;
    for (const ExactPoint& q : p) box.extend(Eigen::Vector3d(q.x(), q.y(), q.z()));
    bvh_.set_slot_box(s, box);
    return std::max(box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff());
  }

  // point_of_vertex_ and the slots of every point, for move_vertices. Made at its first call
  // rather than with the set: the certificate's sets never need them (4 bytes per vertex and 12
  // per face, at millions of faces).
  void index_points_by_vertex(int num_vertices) {
    point_of_vertex_.assign(num_vertices, -1);
    for (std::size_t l = 0; l < point_id_.size(); ++l) point_of_vertex_[point_id_[l]] = static_cast<int>(l);
    slots_of_point_ = group_items(static_cast<int>(points_.size()), [&](auto&& add) {
      for (int s = 0; s < static_cast<int>(shapes_.size()); ++s)
        for (int l : shapes_[s].corner) add(l, s);
    });
  }

  static bool share_id(const std::array<int, 3>& a, const std::array<int, 3>& b) {
    return a[0] == b[0] || a[0] == b[1] || a[0] == b[2] || a[1] == b[0] || a[1] == b[1] || a[1] == b[2] ||
           a[2] == b[0] || a[2] == b[1] || a[2] == b[2];
  }

  struct Ids {
    std::array<int, 3> id;
    int stars_embedded; // all three corners have embedded stars
  };
  struct Shape {
    std::array<int, 3> corner;           // indices into points_
    std::uint8_t dim = 2;                // ExactFace::dim and end at the current positions
    std::array<std::uint8_t, 2> end{};
  };
  FaceBvh bvh_;
  std::vector<Ids> ids_;                 // in slot order
  std::vector<Shape> shapes_;            // in slot order
  std::vector<ExactPoint> points_;       // the faces' vertices at the current positions
  std::vector<int> point_id_;            // the vertex id (row of V) of each of points_
  double margin_ = 0;            // slab_margin of these faces' coordinates (at least)
  std::vector<int> point_of_vertex_; // index of each vertex (row of V) in points_, or -1
  ItemGroups slots_of_point_;        // group l: the slots whose faces use point l
  const char* star_ = nullptr;
};

} // namespace gshell::detail
