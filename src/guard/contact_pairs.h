#pragma once
// The primitives of a shell's boundary surface for contact handling (vertices, edges, triangles),
// which of their pairs count, and the broad phase that finds the pairs whose boxes meet.
//
// Broad phase: a bounding-volume hierarchy over the triangles, each triangle's box the union of
// its corners' boxes (a corner's box: the point grown by a search radius, or swept along a
// motion). Every vertex and every edge is owned by one triangle that contains it; a pair of
// primitives is visited only through the pair of their owners, so each is found once, and is
// found whenever the two primitives' boxes meet (the owners' boxes contain them).
#include "quality/face_bvh.h"

#include <gshell/guard/primitive_distance.h>
#include <gshell/quality/shell_boundary.h>

#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace gshell::detail {

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

  /// The pair's four vertex ids in PairPoints order (vertex v and triangle t, or edges e and f).
  std::array<int, 4> point_triangle(int v, int t) const {
    return {v, triangles_[t][0], triangles_[t][1], triangles_[t][2]};
  }
  std::array<int, 4> edge_edge(int e, int f) const {
    return {edges_[e][0], edges_[e][1], edges_[f][0], edges_[f][1]};
  }

  /// Whether the pair is one of the module's pairs: no shared vertex, not all four vertices
  /// fixed, nothing excluded (contact_guard.h).
  bool point_triangle_allowed(int v, int t) const {
    const auto& c = triangles_[t];
    return v != c[0] && v != c[1] && v != c[2] && !triangle_excluded_[t] && !vertex_excluded_[v] &&
           (movable_[v] || !triangle_fixed_[t]);
  }
  bool edge_edge_allowed(int e, int f) const {
    const auto &a = edges_[e], &b = edges_[f];
    return a[0] != b[0] && a[0] != b[1] && a[1] != b[0] && a[1] != b[1] && !edge_excluded_[e] &&
           !edge_excluded_[f] && !(edge_fixed_[e] && edge_fixed_[f]);
  }

  /// Calls visit(kind, a, b) for every allowed pair, (vertex a, triangle b) or (edge a, edge b)
  /// with a < b, whose boxes meet; a vertex's box is vertex_box[v], an edge's or a triangle's the
  /// union of its vertices' boxes. visit runs concurrently from several threads.
  template <class Visit>
  void for_each_pair(const std::vector<Eigen::AlignedBox3d>& vertex_box, Visit&& visit) const;

private:
  int num_vertices_ = 0;
  std::vector<std::array<int, 3>> triangles_;
  std::vector<std::array<int, 2>> edges_;
  std::vector<int> boundary_vertices_;
  std::vector<char> movable_, vertex_excluded_, triangle_excluded_, triangle_fixed_, edge_excluded_, edge_fixed_;
  // Per triangle, the vertices and edges it owns: owned_*[offsets[t] .. offsets[t + 1]).
  std::vector<int> vertex_owner_offsets_, owned_vertices_, edge_owner_offsets_, owned_edges_;
};

template <class Visit>
void ContactPrimitives::for_each_pair(const std::vector<Eigen::AlignedBox3d>& vertex_box, Visit&& visit) const {
  const int m = num_triangles();
  std::vector<Eigen::AlignedBox3d> box(m);
  for (int t = 0; t < m; ++t) {
    box[t] = vertex_box[triangles_[t][0]];
    box[t].extend(vertex_box[triangles_[t][1]]).extend(vertex_box[triangles_[t][2]]);
  }
  auto edge_box = [&](int e) { return vertex_box[edges_[e][0]].merged(vertex_box[edges_[e][1]]); };
  const FaceBvh tree(box);
  const std::vector<int>& face = tree.faces_in_leaf_order();
  auto owned_against = [&](int f, int g) { // f's vertices against triangle g
    for (int i = vertex_owner_offsets_[f]; i < vertex_owner_offsets_[f + 1]; ++i) {
      const int v = owned_vertices_[i];
      if (point_triangle_allowed(v, g) && exact_boxes_meet(vertex_box[v], box[g])) visit(PairKind::PointTriangle, v, g);
    }
  };
  tree.for_each_overlapping_pair([&](int s, int t) {
    const int f = face[s], g = face[t];
    owned_against(f, g);
    owned_against(g, f);
    for (int i = edge_owner_offsets_[f]; i < edge_owner_offsets_[f + 1]; ++i) {
      const int e = owned_edges_[i];
      const Eigen::AlignedBox3d be = edge_box(e);
      if (!exact_boxes_meet(be, box[g])) continue;
      for (int j = edge_owner_offsets_[g]; j < edge_owner_offsets_[g + 1]; ++j) {
        const int e2 = owned_edges_[j];
        if (edge_edge_allowed(e, e2) && exact_boxes_meet(be, edge_box(e2)))
          visit(PairKind::EdgeEdge, std::min(e, e2), std::max(e, e2));
      }
    }
  });
}

} // namespace gshell::detail
