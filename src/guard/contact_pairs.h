#pragma once
// The primitives of a shell's boundary surface for contact handling (vertices, edges, triangles),
// which of their pairs count, and the broad phase that finds the pairs whose boxes meet.
//
// Broad phase: a bounding-volume hierarchy over the triangles, each triangle's box the union of
// its corners' boxes (a corner's box: the point grown by a search radius, or swept along a
// motion). Every vertex and every edge is owned by one triangle that contains it; a pair of
// primitives is visited only through the pair of their owners, so each is found once, and is
// found whenever the two primitives' boxes meet (the owners' boxes contain them). The records a
// visit reads are laid out in the tree's leaf order: neighbouring slots are neighbours in space,
// so the visits of one subtree stay within a small piece of memory.
//
// The triangles fall into two patches with a tree each: those with a movable corner and the
// fixed ones. A pair of the module has a movable vertex, so its owners are both movable or one
// movable and one fixed: the movable patch is joined with itself and with the fixed patch, never
// the fixed patch with itself. The fixed patch can be kept while the fixed vertices stay put
// (a solver that moves a small region joins only that region against it), and cut down to the
// fixed triangles within reach of a small region (patch's `reach`; docs/contact.md).
#include "geometry/item_groups.h"
#include "quality/face_bvh.h"

#include <gshell/guard/primitive_distance.h>
#include <gshell/quality/shell_boundary.h>

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cmath>
#include <limits>
#include <vector>

namespace gshell::detail {

/// Axis-aligned boxes as six float arrays (structure of arrays: box tests over a run of boxes
/// vectorise), each bound rounded outwards from its double (conservative, half the bytes),
/// measured in a frame near the boxes and of their size (CoverFrame says why).
class FloatBoxes {
public:
  static constexpr int kChunk = 8; ///< boxes per vector step; runs are read in whole chunks

  void resize(std::size_t n) {
    for (int d = 0; d < 3; ++d) { // padded: a run's last chunk may read past its end
      lo_[d].assign(n + kChunk, 0);
      hi_[d].assign(n + kChunk, 0);
    }
  }
  void set(std::size_t i, const Eigen::AlignedBox3d& b, const CoverFrame& frame) {
    for (int d = 0; d < 3; ++d) {
      lo_[d][i] = float_lower_end(b.min()[d], frame.origin[d], frame.scale);
      hi_[d][i] = float_upper_end(b.max()[d], frame.origin[d], frame.scale);
    }
  }
  /// Bit k set iff box i of this meets box first + k of `other`, for k < count <= 32.
  std::uint32_t meets(std::size_t i, const FloatBoxes& other, std::size_t first, int count) const {
    const float l0 = lo_[0][i], l1 = lo_[1][i], l2 = lo_[2][i], h0 = hi_[0][i], h1 = hi_[1][i], h2 = hi_[2][i];
    std::uint32_t mask = 0;
    for (int c = 0; c < count; c += kChunk) {
      const std::size_t o = first + c;
      const float *__restrict ol0 = &other.lo_[0][o], *__restrict ol1 = &other.lo_[1][o], *__restrict ol2 = &other.lo_[2][o];
      const float *__restrict oh0 = &other.hi_[0][o], *__restrict oh1 = &other.hi_[1][o], *__restrict oh2 = &other.hi_[2][o];
      int hit[kChunk]; // a fixed-length loop of int lanes: vectorised on every target at -O3
      for (int k = 0; k < kChunk; ++k)
        hit[k] = (ol0[k] <= h0) & (l0 <= oh0[k]) & (ol1[k] <= h1) & (l1 <= oh1[k]) & (ol2[k] <= h2) & (l2 <= oh2[k]);
      for (int k = 0; k < kChunk; ++k) mask |= static_cast<std::uint32_t>(hit[k]) << (c + k);
    }
    return count >= 32 ? mask : mask & ((std::uint32_t{1} << count) - 1);
  }

  /// The box around boxes [first, first + count) as {lo0, lo1, lo2, hi0, hi1, hi2}.
  std::array<float, 6> hull(std::size_t first, int count) const {
    std::array<float, 6> h = {lo_[0][first], lo_[1][first], lo_[2][first], hi_[0][first], hi_[1][first], hi_[2][first]};
    for (std::size_t i = first + 1; i < first + count; ++i)
      for (int d = 0; d < 3; ++d) {
        h[d] = std::min(h[d], lo_[d][i]);
        h[3 + d] = std::max(h[3 + d], hi_[d][i]);
      }
    return h;
  }
  /// Whether box i meets the box h (as hull() returns it).
  bool meets(std::size_t i, const std::array<float, 6>& h) const {
    return lo_[0][i] <= h[3] && h[0] <= hi_[0][i] && lo_[1][i] <= h[4] && h[1] <= hi_[1][i] && lo_[2][i] <= h[5] &&
           h[2] <= hi_[2][i];
  }

private:
  std::vector<float> lo_[3], hi_[3];
};

class ContactPrimitives;

/// The triangles of one patch in the leaf order of a tree over their boxes, with the vertices
/// and edges they own: what a leaf pair reads, in slot order (made by ContactPrimitives::patch).
struct ContactPatch {
  FaceBvh tree{std::vector<Eigen::AlignedBox3d>{}};
  std::vector<int> triangle;                    ///< per slot: boundary triangle id
  std::vector<int> vertex_begin, edge_begin;    ///< per slot + 1: owned vertices / edges start
  FloatBoxes tri_box, vert_box, edge_box;
  std::vector<std::array<int, 3>> tri_corner;
  std::vector<unsigned char> tri_flags, vert_flags, edge_flags;
  std::vector<int> vert_id, edge_id;
  std::vector<std::array<int, 2>> edge_end;

  int size() const { return static_cast<int>(triangle.size()); }
  /// Whether a triangle of slots [s0, s1) has a corner flagged in `flag` (one per vertex).
  bool touches(int s0, int s1, const std::vector<char>& flag) const {
    for (int s = s0; s < s1; ++s)
      for (int v : tri_corner[s])
        if (flag[v]) return true;
    return false;
  }
};

class ContactPrimitives {
public:
  /// Checks sizes and indices (InputError).
  ContactPrimitives(const ShellBoundary& boundary, int num_vertices, const std::vector<char>& movable,
                    const std::vector<char>& excluded_triangles);

  int num_vertices() const { return num_vertices_; }
  int num_triangles() const { return static_cast<int>(triangles_.size()); }
  int num_edges() const { return static_cast<int>(edges_.size()); }
  /// Vertices some boundary triangle uses, ascending.
  const std::vector<int>& boundary_vertices() const { return boundary_vertices_; }
  /// Corners of triangles that have no movable corner (the fixed patch's vertices), ascending.
  const std::vector<int>& fixed_patch_vertices() const { return fixed_patch_vertices_; }
  /// Whether vertex v is a corner of a triangle without a movable corner.
  bool in_fixed_patch(int v) const { return patch_corner_[v] & 1; }
  /// Corners of triangles that have a movable corner (the movable patch's vertices), ascending.
  const std::vector<int>& movable_patch_vertices() const { return movable_patch_vertices_; }

  /// The pair's four vertex ids in PairPoints order (vertex v and triangle t, or edges e and f).
  std::array<int, 4> point_triangle(int v, int t) const {
    return {v, triangles_[t][0], triangles_[t][1], triangles_[t][2]};
  }
  std::array<int, 4> edge_edge(int e, int f) const {
    return {edges_[e][0], edges_[e][1], edges_[f][0], edges_[f][1]};
  }

  /// How the patches made from now on measure their float boxes (CoverFrame says why), e.g. in
  /// the frame of the shell's box. Patches searched together must be made in the same frame.
  /// Origin 0, scale 1 until set.
  void set_frame(const CoverFrame& frame) { frame_ = frame; }
  const CoverFrame& frame() const { return frame_; }

  /// Triangles with a movable corner (the movable patch's), ascending.
  const std::vector<int>& movable_triangles() const { return patch_triangles_[1]; }
  /// Triangles with no movable corner (the fixed patch's), ascending.
  const std::vector<int>& fixed_triangles() const { return patch_triangles_[0]; }
  /// Corners of triangle t.
  const std::array<int, 3>& triangle(int t) const { return triangles_[t]; }

  /// The movable or the fixed patch, its primitives' boxes from vertex_box (a vertex's box is
  /// vertex_box[v], an edge's or a triangle's the union of its vertices' boxes; only the
  /// patch's vertices are read). With `reach` (a tree over boxes), only the patch's triangles
  /// whose boxes meet one of reach's: a fixed patch cut down to what a small movable region can
  /// meet.
  ContactPatch patch(bool movable, const std::vector<Eigen::AlignedBox3d>& vertex_box,
                     const FaceBvh* reach = nullptr) const;
  /// The same patch (made by patch() over the same triangles) with every box set anew from
  /// vertex_box: its tree keeps its shape and leaf order and is refit (no sort, no allocation).
  void refit(ContactPatch& patch, const std::vector<Eigen::AlignedBox3d>& vertex_box) const;

  /// Calls visit(kind, a, b, vertices) for every pair of the module (no shared vertex, not all
  /// four vertices fixed, nothing excluded: contact_guard.h) whose boxes meet: (vertex a,
  /// triangle b) or (edge a, edge b) with a < b, and the pair's vertex ids in PairPoints order.
  /// `movable` and `fixed` are the two patches made from the same boxes. visit runs concurrently
  /// from several threads. With `touching` (one flag per vertex), at least the pairs with a
  /// flagged vertex: a pair's vertices are corners of the two triangles it is found through, so
  /// leaf pairs with no flagged corner are passed over.
  template <class Visit>
  void for_each_pair(const ContactPatch& movable, const ContactPatch& fixed, Visit&& visit,
                     const std::vector<char>* touching = nullptr) const;

  /// Faces per leaf of the patches' trees: a leaf pair tests all its primitives' boxes in
  /// vectorised runs, so leaves hold more faces than a face-by-face search would want. A leaf
  /// owns at most 3 kLeafFaces edges: runs fit FloatBoxes::meets' 32 bits.
  static constexpr int kLeafFaces = 8;
  /// Flags of a primitive.
  static constexpr unsigned char kExcluded = 1, kFixed = 2;

private:
  // The box around triangle t's corners' boxes.
  Eigen::AlignedBox3d triangle_box(int t, const std::vector<Eigen::AlignedBox3d>& vertex_box) const;
  // Slot s's boxes of its triangle (given), owned vertices and owned edges (from vertex_box).
  static void set_slot_boxes(ContactPatch& p, int s, const Eigen::AlignedBox3d& triangle_box,
                             const std::vector<Eigen::AlignedBox3d>& vertex_box);
  // The pairs between leaf [a0, a1) of patch A and leaf [b0, b1) of patch B (the same leaf of
  // one patch when self).
  template <class Visit>
  static void leaf_pair(const ContactPatch& A, int a0, int a1, const ContactPatch& B, int b0, int b1, bool self,
                        Visit& visit);

  int num_vertices_ = 0;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<std::array<int, 2>> edges_;
  std::vector<int> boundary_vertices_, fixed_patch_vertices_, movable_patch_vertices_;
  std::vector<unsigned char> patch_corner_; // per vertex: bit 0 fixed patch corner, bit 1 movable
  std::vector<unsigned char> vertex_flags_, triangle_flags_, edge_flags_;
  std::vector<int> patch_triangles_[2]; // [0] fixed, [1] movable, ascending
  CoverFrame frame_;
  ItemGroups owned_vertices_, owned_edges_; // group t: the vertices and edges triangle t owns
};

template <class Visit>
void ContactPrimitives::leaf_pair(const ContactPatch& A, int a0, int a1, const ContactPatch& B, int b0, int b1,
                                  bool self, Visit& visit) {
  // Primitives of one leaf are tested against the other leaf's box first: leaves that meet
  // mostly overlap in part.
  const std::array<float, 6> box_a = A.tri_box.hull(a0, a1 - a0), box_b = B.tri_box.hull(b0, b1 - b0);
  // Vertices [from, to) of P against the triangles of slots [t0, t1) of Q (box: theirs).
  auto points_against = [&](const ContactPatch& P, int from, int to, const ContactPatch& Q, int t0, int t1,
                            const std::array<float, 6>& box) {
    for (int i = from; i < to; ++i) {
      if ((P.vert_flags[i] & kExcluded) || !P.vert_box.meets(i, box)) continue;
      const int v = P.vert_id[i];
      for (std::uint32_t hit = P.vert_box.meets(i, Q.tri_box, t0, t1 - t0); hit; hit &= hit - 1) {
        const int t = t0 + std::countr_zero(hit);
        const auto& c = Q.tri_corner[t];
        if (v == c[0] || v == c[1] || v == c[2] || (Q.tri_flags[t] & kExcluded) ||
            (P.vert_flags[i] & Q.tri_flags[t] & kFixed))
          continue;
        visit(PairKind::PointTriangle, v, Q.triangle[t], std::array<int, 4>{v, c[0], c[1], c[2]});
      }
    }
  };
  points_against(A, A.vertex_begin[a0], A.vertex_begin[a1], B, b0, b1, box_b);
  if (!self) points_against(B, B.vertex_begin[b0], B.vertex_begin[b1], A, a0, a1, box_a);
  const int f1 = B.edge_begin[b1];
  for (int i = A.edge_begin[a0]; i < A.edge_begin[a1]; ++i) {
    if ((A.edge_flags[i] & kExcluded) || !A.edge_box.meets(i, box_b)) continue;
    const int f0 = self ? i + 1 : B.edge_begin[b0];
    const auto& p = A.edge_end[i];
    for (std::uint32_t hit = A.edge_box.meets(i, B.edge_box, f0, f1 - f0); hit; hit &= hit - 1) {
      const int j = f0 + std::countr_zero(hit);
      const auto& q = B.edge_end[j];
      if (p[0] == q[0] || p[0] == q[1] || p[1] == q[0] || p[1] == q[1] || (B.edge_flags[j] & kExcluded) ||
          (A.edge_flags[i] & B.edge_flags[j] & kFixed))
        continue;
      const int e = A.edge_id[i], g = B.edge_id[j];
      if (e < g) visit(PairKind::EdgeEdge, e, g, std::array<int, 4>{p[0], p[1], q[0], q[1]});
      else visit(PairKind::EdgeEdge, g, e, std::array<int, 4>{q[0], q[1], p[0], p[1]});
    }
  }
}

template <class Visit>
void ContactPrimitives::for_each_pair(const ContactPatch& movable, const ContactPatch& fixed, Visit&& visit,
                                      const std::vector<char>* touching) const {
  auto wanted = [&](const ContactPatch& A, int a0, int a1, const ContactPatch& B, int b0, int b1) {
    return !touching || A.touches(a0, a1, *touching) || B.touches(b0, b1, *touching);
  };
  movable.tree.for_each_overlapping_leaf_pair([&](int a0, int a1, int b0, int b1) {
    if (wanted(movable, a0, a1, movable, b0, b1)) leaf_pair(movable, a0, a1, movable, b0, b1, a0 == b0, visit);
  });
  movable.tree.for_each_overlapping_leaf_pair(fixed.tree, [&](int a0, int a1, int b0, int b1) {
    if (wanted(movable, a0, a1, fixed, b0, b1)) leaf_pair(movable, a0, a1, fixed, b0, b1, false, visit);
  });
}

} // namespace gshell::detail
