#include <gshell/quality/thickness.h>

#include <gshell/error.h>

#include "quality/check_mesh_input.h"
#include "quality/face_bvh.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <vector>

namespace gshell {

Eigen::VectorXd vertex_thickness(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                 const Eigen::MatrixXd& top) {
  detail::check_triangle_mesh(base, F, "thickness (base)");
  if (top.rows() > 0 && (top.cols() != 3 || !top.allFinite()))
    throw InputError("thickness (top): expected finite n x 3 vertex positions");
  if (F.rows() == 0) throw InputError("thickness (base): the base has no faces");

  const detail::FaceBvh bvh(base, F, detail::FaceBvh::Use::distances);
  const bool paired = top.rows() == base.rows();
  // Query order: vertices of the faces in the tree's leaf order, so that consecutive queries
  // walk the same part of the tree (cache-friendly). Vertices on no face come last.
  // Paired base vertex i lies on the base surface if a face uses it; its distance to top vertex
  // i (the shell's pairing) is then a tight starting bound that prunes most of the tree.
  std::vector<int> order;
  std::vector<char> on_surface(base.rows(), 0);
  if (paired) {
    order.reserve(top.rows());
    for (int f : bvh.faces_in_leaf_order())
      for (int k = 0; k < 3; ++k)
        if (!on_surface[F(f, k)]) {
          on_surface[F(f, k)] = 1;
          order.push_back(F(f, k));
        }
  }
  for (int i = 0; i < top.rows(); ++i)
    if (!paired || !on_surface[i]) order.push_back(i);

  Eigen::VectorXd thickness(top.rows());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, order.size(), 256), [&](const auto& r) {
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const int i = order[k];
      const Eigen::Vector3d q = top.row(i).transpose();
      if (!paired || !on_surface[i]) {
        thickness[i] = std::sqrt(bvh.squared_distance(q, std::numeric_limits<double>::infinity()));
        continue;
      }
      const auto seen_from_its_side = [&](int f) {
        const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
        if (a == i || b == i || c == i) return true;
        const Eigen::Vector3d pa = base.row(a).transpose(), pb = base.row(b).transpose(), pc = base.row(c).transpose();
        return (pb - pa).cross(pc - pa).dot(q - pa) > 0;
      };
      thickness[i] = std::sqrt(bvh.squared_distance(q, (q - base.row(i).transpose()).squaredNorm(), seen_from_its_side));
    }
  });
  return thickness;
}

} // namespace gshell
