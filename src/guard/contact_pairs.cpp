#include "guard/contact_pairs.h"

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>

#include <tbb/parallel_for.h>

#include <string>

namespace gshell::detail {

ContactPrimitives::ContactPrimitives(const ShellBoundary& boundary, int num_vertices, const std::vector<char>& movable,
                                     const std::vector<char>& excluded_triangles)
    : num_vertices_(num_vertices) {
  const int m = boundary.size();
  if (num_vertices < 0) throw InputError("ContactGuard: negative vertex count");
  if (static_cast<int>(movable.size()) != num_vertices)
    throw InputError("ContactGuard: " + std::to_string(movable.size()) + " movable flags for " +
                     std::to_string(num_vertices) + " vertices");
  if (!excluded_triangles.empty() && static_cast<int>(excluded_triangles.size()) != m)
    throw InputError("ContactGuard: " + std::to_string(excluded_triangles.size()) + " excluded-triangle flags for " +
                     std::to_string(m) + " boundary triangles");
  if (m > 0 && boundary.F.cols() != 3) throw InputError("ContactGuard: boundary triangles must be an m x 3 matrix");
  for (int t = 0; t < m; ++t)
    for (int k = 0; k < 3; ++k)
      if (boundary.F(t, k) < 0 || boundary.F(t, k) >= num_vertices)
        throw InputError("ContactGuard: boundary triangle " + std::to_string(t) + " has vertex id " +
                         std::to_string(boundary.F(t, k)) + " outside 0.." + std::to_string(num_vertices - 1));

  const EdgeIncidence incidence = edge_incidence(boundary.F, num_vertices);
  for (int t = 0; t < m; ++t)
    if (!incidence.face_used[t])
      throw InputError("ContactGuard: boundary triangle " + std::to_string(t) + " repeats a vertex");

  triangles_.resize(m);
  triangle_flags_.assign(m, 0);
  vertex_flags_.assign(num_vertices, 0);
  for (int v = 0; v < num_vertices; ++v)
    if (!movable[v]) vertex_flags_[v] = kFixed;
  std::vector<int> vertex_owner(num_vertices, -1);
  for (int t = 0; t < m; ++t) {
    triangles_[t] = {boundary.F(t, 0), boundary.F(t, 1), boundary.F(t, 2)};
    const bool excluded = !excluded_triangles.empty() && excluded_triangles[t];
    if (excluded) triangle_flags_[t] |= kExcluded;
    if (!movable[triangles_[t][0]] && !movable[triangles_[t][1]] && !movable[triangles_[t][2]])
      triangle_flags_[t] |= kFixed;
    for (int v : triangles_[t]) {
      if (vertex_owner[v] < 0) vertex_owner[v] = t;
      if (excluded) vertex_flags_[v] |= kExcluded;
    }
  }
  for (int v = 0; v < num_vertices; ++v)
    if (vertex_owner[v] >= 0) boundary_vertices_.push_back(v);

  const int num_edges = incidence.num_edges();
  edges_.resize(num_edges);
  edge_flags_.assign(num_edges, 0);
  std::vector<int> edge_owner(num_edges);
  for (int e = 0; e < num_edges; ++e) {
    edges_[e] = {incidence.edges(e, 0), incidence.edges(e, 1)};
    if (!movable[edges_[e][0]] && !movable[edges_[e][1]]) edge_flags_[e] |= kFixed;
    edge_owner[e] = incidence.halfedges[incidence.offsets[e]] / 3; // lowest face: half-edges ascend
    for (int i = incidence.offsets[e]; i < incidence.offsets[e + 1]; ++i)
      if (triangle_flags_[incidence.halfedges[i] / 3] & kExcluded) edge_flags_[e] |= kExcluded;
  }

  auto owned_by_triangle = [m](const std::vector<int>& owner) {
    return group_items(m, [&](auto&& add) {
      for (int i = 0; i < static_cast<int>(owner.size()); ++i)
        if (owner[i] >= 0) add(owner[i], i);
    });
  };
  owned_vertices_ = owned_by_triangle(vertex_owner);
  owned_edges_ = owned_by_triangle(edge_owner);

  // Per vertex, bit 0: a corner of a fixed triangle, bit 1: of a movable one.
  patch_corner_.assign(num_vertices, 0);
  for (int t = 0; t < m; ++t) {
    const bool fixed = triangle_flags_[t] & kFixed;
    patch_triangles_[fixed ? 0 : 1].push_back(t);
    for (int v : triangles_[t]) patch_corner_[v] |= fixed ? 1 : 2;
  }
  for (int v = 0; v < num_vertices; ++v) {
    if (patch_corner_[v] & 1) fixed_patch_vertices_.push_back(v);
    if (patch_corner_[v] & 2) movable_patch_vertices_.push_back(v);
  }
}

ContactPatch ContactPrimitives::patch(bool movable, const std::vector<Eigen::AlignedBox3d>& vertex_box,
                                      const FaceBvh* reach) const {
  const std::vector<int>& all = patch_triangles_[movable ? 1 : 0];
  std::vector<int> kept;
  if (reach) {
    std::vector<char> meets(all.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, all.size(), 4096), [&](const auto& r) {
      for (std::size_t i = r.begin(); i < r.end(); ++i) meets[i] = reach->some_face_box_meets(triangle_box(all[i], vertex_box));
    });
    for (std::size_t i = 0; i < all.size(); ++i)
      if (meets[i]) kept.push_back(all[i]);
  }
  const std::vector<int>& tris = reach ? kept : all;
  const int m = static_cast<int>(tris.size());
  ContactPatch p;
  if (m == 0) return p;
  std::vector<Eigen::AlignedBox3d> box(m);
  tbb::parallel_for(tbb::blocked_range<int>(0, m, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) box[i] = triangle_box(tris[i], vertex_box);
  });
  p.tree = FaceBvh(box, kLeafFaces, frame_);
  const std::vector<int>& local = p.tree.faces_in_leaf_order();

  // Slot s: triangle tris[local[s]], then the vertices and edges it owns, so a leaf's (a slot
  // range's) triangles, vertices and edges are three runs, with their ids and flags.
  p.triangle.resize(m);
  p.vertex_begin.assign(m + 1, 0);
  p.edge_begin.assign(m + 1, 0);
  for (int s = 0; s < m; ++s) {
    const int f = p.triangle[s] = tris[local[s]];
    p.vertex_begin[s + 1] = p.vertex_begin[s] + owned_vertices_.start[f + 1] - owned_vertices_.start[f];
    p.edge_begin[s + 1] = p.edge_begin[s] + owned_edges_.start[f + 1] - owned_edges_.start[f];
  }
  const int nv = p.vertex_begin[m], ne = p.edge_begin[m];
  p.tri_box.resize(m);
  p.vert_box.resize(nv);
  p.edge_box.resize(ne);
  p.tri_corner.resize(m);
  p.tri_flags.resize(m);
  p.vert_id.resize(nv);
  p.vert_flags.resize(nv);
  p.edge_id.resize(ne);
  p.edge_end.resize(ne);
  p.edge_flags.resize(ne);
  tbb::parallel_for(tbb::blocked_range<int>(0, m, 2048), [&](const tbb::blocked_range<int>& r) {
    for (int s = r.begin(); s < r.end(); ++s) {
      const int f = p.triangle[s];
      p.tri_corner[s] = triangles_[f];
      p.tri_flags[s] = triangle_flags_[f];
      int out = p.vertex_begin[s];
      for (int i = owned_vertices_.start[f]; i < owned_vertices_.start[f + 1]; ++i, ++out) {
        const int v = owned_vertices_.item[i];
        p.vert_id[out] = v;
        p.vert_flags[out] = vertex_flags_[v];
      }
      out = p.edge_begin[s];
      for (int i = owned_edges_.start[f]; i < owned_edges_.start[f + 1]; ++i, ++out) {
        const int e = owned_edges_.item[i];
        p.edge_id[out] = e;
        p.edge_end[out] = edges_[e];
        p.edge_flags[out] = edge_flags_[e];
      }
      set_slot_boxes(p, s, box[local[s]], vertex_box);
    }
  });
  return p;
}

Eigen::AlignedBox3d ContactPrimitives::triangle_box(int t, const std::vector<Eigen::AlignedBox3d>& vertex_box) const {
  const auto& c = triangles_[t];
  Eigen::AlignedBox3d b = vertex_box[c[0]];
  return b.extend(vertex_box[c[1]]).extend(vertex_box[c[2]]);
}

void ContactPrimitives::set_slot_boxes(ContactPatch& p, int s, const Eigen::AlignedBox3d& triangle_box,
                                       const std::vector<Eigen::AlignedBox3d>& vertex_box) {
  // The patch's float boxes are measured in its tree's frame (the primitives' when it was made).
  const CoverFrame& frame = p.tree.frame();
  p.tri_box.set(s, triangle_box, frame);
  for (int i = p.vertex_begin[s]; i < p.vertex_begin[s + 1]; ++i) p.vert_box.set(i, vertex_box[p.vert_id[i]], frame);
  for (int i = p.edge_begin[s]; i < p.edge_begin[s + 1]; ++i)
    p.edge_box.set(i, vertex_box[p.edge_end[i][0]].merged(vertex_box[p.edge_end[i][1]]), frame);
}

void ContactPrimitives::refit(ContactPatch& p, const std::vector<Eigen::AlignedBox3d>& vertex_box) const {
  tbb::parallel_for(tbb::blocked_range<int>(0, p.size(), 2048), [&](const tbb::blocked_range<int>& r) {
    for (int s = r.begin(); s < r.end(); ++s) {
      const Eigen::AlignedBox3d box = triangle_box(p.triangle[s], vertex_box);
      p.tree.set_slot_box(s, box);
      set_slot_boxes(p, s, box, vertex_box);
    }
  });
  p.tree.refit_nodes();
}

} // namespace gshell::detail
