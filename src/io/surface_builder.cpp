#include "surface_readers.h"

namespace gshell::io_detail {

void SurfaceBuilder::add_fan(std::vector<int>& out, const std::vector<int>& ids) {
  for (std::size_t k = 1; k + 1 < ids.size(); ++k) {
    out.push_back(ids[0]);
    out.push_back(ids[k]);
    out.push_back(ids[k + 1]);
  }
}

TriMesh SurfaceBuilder::finish() const {
  TriMesh mesh;
  const Eigen::Index n = static_cast<Eigen::Index>(xyz.size() / 3);
  const Eigen::Index m = static_cast<Eigen::Index>(corners.size() / 3);
  mesh.V = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(xyz.data(), n, 3);
  mesh.F = Eigen::Map<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(corners.data(), m, 3);
  if (!uv.empty() && uv_corners.size() == corners.size()) {
    mesh.UV = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>>(
        uv.data(), static_cast<Eigen::Index>(uv.size() / 2), 2);
    mesh.FUV = Eigen::Map<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(uv_corners.data(), m, 3);
  }
  return mesh;
}

} // namespace gshell::io_detail
