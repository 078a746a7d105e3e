#include "quality/boundary_rows.h"

#include "quality/face_bvh.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

namespace gshell::detail {

namespace {

Eigen::AlignedBox3d row_box(const ShellBoundary& boundary, const Eigen::MatrixXd& X, int r) {
  Eigen::AlignedBox3d box(X.row(boundary.F(r, 0)).transpose());
  box.extend(X.row(boundary.F(r, 1)).transpose()).extend(X.row(boundary.F(r, 2)).transpose());
  return box;
}

} // namespace

Eigen::MatrixXi rows_of(const Eigen::MatrixXi& B, const std::vector<int>& ids) {
  Eigen::MatrixXi S(static_cast<int>(ids.size()), 3);
  for (std::size_t i = 0; i < ids.size(); ++i) S.row(static_cast<int>(i)) = B.row(ids[i]);
  return S;
}

std::vector<char> rows_near(const ShellBoundary& boundary, const Eigen::MatrixXd& X, const std::vector<int>& seeds,
                            double reach) {
  std::vector<char> near(boundary.size(), 0);
  if (seeds.empty()) return near;
  const Eigen::Vector3d grow = Eigen::Vector3d::Constant(reach);
  std::vector<Eigen::AlignedBox3d> grown;
  grown.reserve(seeds.size());
  for (int r : seeds) {
    const Eigen::AlignedBox3d box = row_box(boundary, X, r);
    grown.emplace_back(box.min() - grow, box.max() + grow);
  }
  const FaceBvh tree(grown);
  tbb::parallel_for(tbb::blocked_range<int>(0, boundary.size(), 4096), [&](const tbb::blocked_range<int>& range) {
    for (int r = range.begin(); r < range.end(); ++r) near[r] = tree.some_face_box_meets(row_box(boundary, X, r));
  });
  return near;
}

} // namespace gshell::detail
