#pragma once
// Exact pair searches over the faces of one or two meshes: the bounding-volume hierarchy finds
// the pairs whose boxes meet, an exact test (exact_faces.h) decides each, in parallel.
#include "quality/exact_faces.h"
#include "quality/face_bvh.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
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
class FaceSet {
public:
  FaceSet(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const std::vector<char>* embedded_star = nullptr)
      : bvh_(V, F, FaceBvh::Use::pairs) {
    take_positions(V, F, embedded_star);
  }

  /// The same faces (F as constructed) at new positions V, with new star flags: the tree is refit
  /// (FaceBvh::set_slot_box, refit_nodes), not rebuilt, so a sequence of frames of one motion costs
  /// less per frame.
  void move_to(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const std::vector<char>* embedded_star = nullptr) {
    take_positions(V, F, embedded_star);
    bvh_.refit_nodes();
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
  // Ids are kept apart from the shapes: most pairs of a fine surface are neighbours settled by
  // their ids and stars, and 12 bytes per face stay in cache where 100 would not.
  static bool meet(const FaceSet& a, int s, const FaceSet& b, int t) {
    const Ids &ia = a.ids_[s], &ib = b.ids_[t];
    if ((ia.stars_embedded || ib.stars_embedded) && share_id(ia.id, ib.id)) return false; // in an embedded star
    const SharedCorners shared = shared_corners(ia.id, ib.id);
    if (a.star_ && (shared.count == 1 || shared.count == 2))
      for (int i = 0; i < shared.count; ++i)
        if (a.star_[ia.id[shared.in_a[i]]]) return false;
    if (shared.count == 0 &&
        slabs_separate(a.faces_[s], a.slabs_[s], b.faces_[t], b.slabs_[t], std::max(a.margin_, b.margin_)))
      return false;
    return faces_intersect_beyond_shared(a.faces_[s], b.faces_[t], shared);
  }

  // The faces' exact shapes at V and their boxes in the tree (one pass: each face's corners are
  // read once; after a build the boxes are those the build set, so only a refit needs them).
  void take_positions(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const std::vector<char>* embedded_star) {
    const int count = bvh_.num_faces();
    const std::vector<int>& face = bvh_.faces_in_leaf_order();
    faces_.resize(count);
    ids_.resize(count);
    slabs_.resize(count);
    star_ = embedded_star ? embedded_star->data() : nullptr;
    const double max_abs = tbb::parallel_reduce(
        tbb::blocked_range<int>(0, count, 4096), 0.0,
        [&](const tbb::blocked_range<int>& r, double largest) {
          for (int s = r.begin(); s < r.end(); ++s) {
            faces_[s] = exact_face(V, F, face[s]);
            const std::array<int, 3>& id = faces_[s].id;
            ids_[s] = {id, star_ && star_[id[0]] && star_[id[1]] && star_[id[2]]};
            slabs_[s] = face_slab(faces_[s]);
            Eigen::AlignedBox3d box;
            for (const ExactPoint& p : faces_[s].p) box.extend(Eigen::Vector3d(p.x(), p.y(), p.z()));
            bvh_.set_slot_box(s, box);
            largest = std::max({largest, box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff()});
          }
          return largest;
        },
        [](double a, double b) { return std::max(a, b); });
    margin_ = slab_margin(max_abs);
  }

  static bool share_id(const std::array<int, 3>& a, const std::array<int, 3>& b) {
    return a[0] == b[0] || a[0] == b[1] || a[0] == b[2] || a[1] == b[0] || a[1] == b[1] || a[1] == b[2] ||
           a[2] == b[0] || a[2] == b[1] || a[2] == b[2];
  }

  struct Ids {
    std::array<int, 3> id;
    int stars_embedded; // all three corners have embedded stars
  };
  FaceBvh bvh_;
  std::vector<ExactFace> faces_; // in slot order
  std::vector<Ids> ids_;         // in slot order
  std::vector<FaceSlab> slabs_;  // in slot order
  double margin_ = 0;            // slab_margin of these faces' coordinates
  const char* star_ = nullptr;
};

} // namespace gshell::detail
