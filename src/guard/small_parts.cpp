#include "guard/small_parts.h"

#include "geometry/disjoint_sets.h"

#include <limits>

namespace gshell::detail {

std::vector<int> small_part_vertices(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double radius) {
  const int n = static_cast<int>(V.rows());
  DisjointSets sets(n);
  std::vector<char> used(n, 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      used[F(f, k)] = 1;
      sets.unite(F(f, 0), F(f, k));
    }
  // Per part, by its root: bounding box, then the farthest vertex from the box's centre.
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<Eigen::Vector3d> lo(n, Eigen::Vector3d::Constant(inf)), hi(n, Eigen::Vector3d::Constant(-inf));
  std::vector<double> radius2(n, 0);
  for (int v = 0; v < n; ++v)
    if (used[v]) {
      const int r = sets.find(v);
      lo[r] = lo[r].cwiseMin(V.row(v).transpose());
      hi[r] = hi[r].cwiseMax(V.row(v).transpose());
    }
  for (int v = 0; v < n; ++v)
    if (used[v]) {
      const int r = sets.find(v);
      radius2[r] = std::max(radius2[r], (V.row(v).transpose() - 0.5 * (lo[r] + hi[r])).squaredNorm());
    }
  std::vector<int> small;
  for (int v = 0; v < n; ++v)
    if (used[v] && radius2[sets.find(v)] < radius * radius) small.push_back(v);
  return small;
}

} // namespace gshell::detail
