#include "guard/contact_pairs.h"

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>

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

  auto group = [m](const std::vector<int>& owner, std::vector<int>& offsets, std::vector<int>& owned) {
    offsets.assign(m + 1, 0);
    for (int o : owner)
      if (o >= 0) ++offsets[o + 1];
    for (int t = 0; t < m; ++t) offsets[t + 1] += offsets[t];
    owned.resize(offsets[m]);
    std::vector<int> next(offsets.begin(), offsets.end() - 1);
    for (int i = 0; i < static_cast<int>(owner.size()); ++i)
      if (owner[i] >= 0) owned[next[owner[i]]++] = i;
  };
  group(vertex_owner, vertex_owner_offsets_, owned_vertices_);
  group(edge_owner, edge_owner_offsets_, owned_edges_);
}

} // namespace gshell::detail
