// Curvature-sensitive ideal prisms (see the header).
#include <gshell/shell/curvature_prisms.h>

#include <gshell/error.h>

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace gshell {

void check_curvature_clamp(double s_min, double s_max) {
  if (!(std::isfinite(s_min) && std::isfinite(s_max) && s_min > 0 && s_min <= 1 && s_max >= 1)) {
    std::ostringstream msg;
    msg << "curvature prisms need 0 < s_min <= 1 <= s_max (got s_min = " << s_min
        << ", s_max = " << s_max << ")";
    throw InputError(msg.str());
  }
}

PrismCorners curvature_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                              const FaceCurvature& curvature, double eta, double s_min,
                              double s_max, int* clamped) {
  check_curvature_clamp(s_min, s_max);
  if (!(std::isfinite(eta) && eta > 0))
    throw InputError("curvature prisms need a positive finite thickness");
  const Eigen::Index m = F.rows();
  if (curvature.k1.size() != m || curvature.k2.size() != m || curvature.e1.rows() != m ||
      curvature.e2.rows() != m)
    throw InputError("curvature prisms: curvature does not match the faces");

  PrismCorners P(6 * m, 3);
  tbb::combinable<int> clamp_count([] { return 0; });
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, m), [&](const auto& r) {
    int local_clamped = 0;
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      const Eigen::Vector3d x = (b - a).cross(c - a);
      const Eigen::Vector3d normal = x.norm() > 0 ? Eigen::Vector3d(x.normalized()) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d centroid = (a + b + c) / 3.0;
      const double raw1 = 1 + eta * curvature.k1(f), raw2 = 1 + eta * curvature.k2(f);
      const double s1 = std::clamp(raw1, s_min, s_max), s2 = std::clamp(raw2, s_min, s_max);
      if (s1 != raw1 || s2 != raw2) ++local_clamped;
      const Eigen::Vector3d e1 = curvature.e1.row(f), e2 = curvature.e2.row(f);
      // Scaling along an orthonormal in-plane frame: x -> x + (s1-1)(x.e1)e1 + (s2-1)(x.e2)e2.
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d p = V.row(F(f, j));
        const Eigen::Vector3d d = p - centroid;
        const Eigen::Vector3d top =
            p + (s1 - 1) * d.dot(e1) * e1 + (s2 - 1) * d.dot(e2) * e2 + eta * normal;
        P.row(6 * f + j) = p;
        P.row(6 * f + 3 + j) = top;
      }
    }
    clamp_count.local() += local_clamped;
  });
  if (clamped) *clamped = clamp_count.combine(std::plus<int>());
  return P;
}

PrismCorners curvature_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta,
                              double s_min, double s_max, int* clamped) {
  check_curvature_clamp(s_min, s_max);
  return curvature_prisms(V, F, face_curvature(V, F), eta, s_min, s_max, clamped);
}

} // namespace gshell
