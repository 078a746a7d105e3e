#include "quality/nested_parts.h"

#include <gshell/shell/prism_tets.h>

#include "geometry/disjoint_sets.h"
#include "quality/filtered_orientation.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace gshell::detail {

ShellParts shell_parts(const Eigen::MatrixXi& F, int n) {
  DisjointSets sets(n);
  std::vector<char> used(n, 0);
  for (int f = 0; f < F.rows(); ++f) {
    used[F(f, 0)] = used[F(f, 1)] = used[F(f, 2)] = 1;
    sets.unite(F(f, 0), F(f, 1));
    sets.unite(F(f, 0), F(f, 2));
  }
  ShellParts parts;
  parts.of_vertex.assign(n, -1);
  std::vector<int> part_of_root(n, -1);
  for (int v = 0; v < n; ++v) {
    if (!used[v]) continue;
    int& part = part_of_root[sets.find(v)];
    if (part < 0) { // v is the part's lowest vertex
      part = parts.count();
      parts.probe.push_back(v);
    }
    parts.of_vertex[v] = part;
  }
  return parts;
}

std::vector<char> parts_with_flagged_rows(const ShellParts& parts, const ShellBoundary& boundary,
                                          const std::vector<char>& rows, int n) {
  std::vector<char> flagged(parts.count(), 0);
  for (int r = 0; r < boundary.size(); ++r)
    if (rows[r]) flagged[parts.of_vertex[boundary.F(r, 0) % n]] = 1;
  return flagged;
}

std::vector<std::pair<int, int>> nested_probes(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                               const Eigen::MatrixXi& F, const ShellParts& parts) {
  if (parts.count() < 2) return {};
  const int n = static_cast<int>(base.rows()), m = static_cast<int>(F.rows());
  using RowMajorPoints = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  const RowMajorPoints B = base, T = top;
  // The probes sorted by x: a tet visits only those within its box's x range.
  // Each with what the scan reads (its point and part), not indices into the shell: a face
  // scans a few to tens of them.
  struct Probe {
    double x, y, z;
    int vertex; // shell vertex: base i or top n + i
    int part;
  };
  std::vector<Probe> probes;
  for (int k = 0; k < parts.count(); ++k) {
    const int i = parts.probe[k];
    probes.push_back({B(i, 0), B(i, 1), B(i, 2), i, k});
    probes.push_back({T(i, 0), T(i, 1), T(i, 2), n + i, k});
  }
  std::sort(probes.begin(), probes.end(), [](const Probe& a, const Probe& b) { return a.x < b.x; });
  auto point = [&](int v) { return v < n ? B.row(v).data() : T.row(v - n).data(); };

  tbb::enumerable_thread_specific<std::vector<std::pair<int, int>>> found;
  tbb::parallel_for(tbb::blocked_range<int>(0, m, 4096), [&](const tbb::blocked_range<int>& r) {
    std::vector<int> near; // probes of other parts in the prism's box
    for (int f = r.begin(); f < r.end(); ++f) {
      const int part = parts.of_vertex[F(f, 0)];
      const double* corner[6];
      for (int k = 0; k < 3; ++k) {
        corner[k] = B.row(F(f, k)).data();
        corner[k + 3] = T.row(F(f, k)).data();
      }
      // The prism's box first: it holds most probes' x range empty, and its three tets would
      // each have made a box and searched the probes (called at every check of the valid start
      // and of the lifting, on a shell with hundreds of parts this pass was a quarter of the run).
      Eigen::Array3d lo = Eigen::Array3d::Constant(INFINITY), hi = -lo;
      for (const double* p : corner) {
        const Eigen::Array3d q(p[0], p[1], p[2]);
        lo = lo.min(q);
        hi = hi.max(q);
      }
      near.clear();
      auto k = std::lower_bound(probes.begin(), probes.end(), lo[0], [](const Probe& p, double x) { return p.x < x; });
      for (; k != probes.end() && k->x <= hi[0]; ++k)
        if (k->part != part && k->y >= lo[1] && k->y <= hi[1] && k->z >= lo[2] && k->z <= hi[2])
          near.push_back(k->vertex);
      if (near.empty()) continue;
      const auto tets = prism_corner_tets(F(f, 0), F(f, 1), F(f, 2));
      for (int t = 0; t < 3; ++t) {
        const std::array<const double*, 4> c = {corner[tets[t][0]], corner[tets[t][1]], corner[tets[t][2]],
                                                corner[tets[t][3]]};
        if (orientation_sign(c[0], c[1], c[2], c[3]) <= 0) continue; // inverted or flat: no inside
        for (const int v : near) {
          // Inside the closed tet: on the positive side of (or on) each of its four faces.
          const double* p = point(v);
          if (orientation_sign(p, c[1], c[2], c[3]) >= 0 && orientation_sign(c[0], p, c[2], c[3]) >= 0 &&
              orientation_sign(c[0], c[1], p, c[3]) >= 0 && orientation_sign(c[0], c[1], c[2], p) >= 0)
            found.local().emplace_back(v, 3 * f + t);
        }
      }
    }
  });
  std::vector<std::pair<int, int>> out;
  for (const auto& part : found) out.insert(out.end(), part.begin(), part.end());
  std::sort(out.begin(), out.end());
  // One entry per probe (a probe on a face shared by two tets is in both).
  out.erase(std::unique(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
            out.end());
  return out;
}

} // namespace gshell::detail
