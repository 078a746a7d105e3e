#include <gshell/quality/thickness.h>

#include <gshell/error.h>

#include "quality/check_mesh_input.h"
#include "quality/closest_point_tree.h"

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

  const detail::ClosestPointTree tree(base, F);
  // Base vertex i lies on the base surface if a face uses it; its distance to top vertex i (the
  // shell's pairing) is then a tight starting bound that prunes most of the tree.
  std::vector<char> on_surface(base.rows(), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) on_surface[F(f, k)] = 1;
  const bool paired = top.rows() == base.rows();

  Eigen::VectorXd thickness(top.rows());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, top.rows(), 256), [&](const auto& r) {
    for (Eigen::Index i = r.begin(); i < r.end(); ++i) {
      const Eigen::Vector3d q = top.row(i).transpose();
      double bound2 = std::numeric_limits<double>::infinity();
      if (paired && on_surface[i]) bound2 = (q - base.row(i).transpose()).squaredNorm();
      thickness[i] = std::sqrt(tree.squared_distance(q, bound2));
    }
  });
  return thickness;
}

} // namespace gshell
