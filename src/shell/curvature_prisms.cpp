// Curvature-sensitive ideal prisms (see the header).
#include <gshell/shell/curvature_prisms.h>

#include "quality/check_mesh_input.h"

#include <gshell/error.h>
#include <gshell/shell/prism_tets.h>

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

namespace gshell {
namespace {

/// One face's prism: base corners, centroid, unit normal and principal frame.
struct PrismFrame {
  std::array<Eigen::Vector3d, 3> base;
  Eigen::Vector3d centroid, normal, e1, e2;
};

/// Top corners for scale factors (s1, s2). The base lies in span(e1, e2) around the centroid, so
/// x -> x + (s1-1)(d.e1)e1 + (s2-1)(d.e2)e2 scales it about the centroid in its plane.
std::array<Eigen::Vector3d, 3> top_corners(const PrismFrame& p, double s1, double s2, double eta) {
  std::array<Eigen::Vector3d, 3> top;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d d = p.base[j] - p.centroid;
    top[j] = p.base[j] + (s1 - 1) * d.dot(p.e1) * p.e1 + (s2 - 1) * d.dot(p.e2) * p.e2 + eta * p.normal;
  }
  return top;
}

/// Smallest volume of the prism's 3 tets; `corners`: the face's prism_corner_tets.
double min_tet_volume(const PrismFrame& p, const std::array<Eigen::Vector3d, 3>& top,
                      const std::array<std::array<int, 4>, 3>& corners) {
  auto corner = [&](int c) -> const Eigen::Vector3d& { return c < 3 ? p.base[c] : top[c - 3]; };
  double smallest = INFINITY;
  for (const auto& tet : corners) {
    const Eigen::Vector3d& x0 = corner(tet[0]);
    const double volume = (corner(tet[1]) - x0).cross(corner(tet[2]) - x0).dot(corner(tet[3]) - x0) / 6;
    smallest = std::min(smallest, volume);
  }
  return smallest;
}

} // namespace

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
                              double s_max, CurvaturePrismStats* stats) {
  check_curvature_clamp(s_min, s_max);
  if (!(std::isfinite(eta) && eta > 0))
    throw InputError("curvature prisms need a positive finite thickness");
  if (V.rows() > 0 && V.cols() != 3) throw InputError("curvature prisms: V must be n x 3");
  detail::check_face_indices(F, V.rows(), "curvature prisms");
  const Eigen::Index m = F.rows();
  if (curvature.k1.size() != m || curvature.k2.size() != m || curvature.e1.rows() != m ||
      curvature.e2.rows() != m)
    throw InputError("curvature prisms: curvature does not match the faces");

  PrismCorners P(6 * m, 3);
  tbb::combinable<CurvaturePrismStats> counts;
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, m), [&](const auto& r) {
    CurvaturePrismStats& local = counts.local();
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      PrismFrame p;
      for (int j = 0; j < 3; ++j) p.base[j] = V.row(F(f, j));
      const Eigen::Vector3d x = (p.base[1] - p.base[0]).cross(p.base[2] - p.base[0]);
      const double area = 0.5 * x.norm();
      p.normal = area > 0 ? Eigen::Vector3d(x.normalized()) : Eigen::Vector3d::Zero();
      p.centroid = (p.base[0] + p.base[1] + p.base[2]) / 3.0;
      p.e1 = curvature.e1.row(f);
      p.e2 = curvature.e2.row(f);
      const double raw1 = 1 + eta * curvature.k1(f), raw2 = 1 + eta * curvature.k2(f);
      double s1 = std::clamp(raw1, s_min, s_max), s2 = std::clamp(raw2, s_min, s_max);
      if (!(s1 == raw1 && s2 == raw2)) ++local.clamped;

      std::array<Eigen::Vector3d, 3> top = top_corners(p, s1, s2, eta);
      const double required = s_min * s_min * eta * area / 3;
      const auto corners = prism_corner_tets(F(f, 0), F(f, 1), F(f, 2));
      if (area > 0 && s1 != s2 && min_tet_volume(p, top, corners) < required) {
        // Largest blend t in [0,1] (t = 0: isotropic, always sound) that keeps the volumes.
        const double log_iso = 0.5 * (std::log(s1) + std::log(s2));
        auto blended = [&](double t, double s) { return std::exp((1 - t) * log_iso + t * std::log(s)); };
        double good = 0, bad = 1;
        for (int it = 0; it < 30; ++it) {
          const double t = 0.5 * (good + bad);
          if (min_tet_volume(p, top_corners(p, blended(t, s1), blended(t, s2), eta), corners) >= required)
            good = t;
          else
            bad = t;
        }
        s1 = blended(good, s1);
        s2 = blended(good, s2);
        top = top_corners(p, s1, s2, eta);
        ++local.limited;
      }
      for (int j = 0; j < 3; ++j) {
        P.row(6 * f + j) = p.base[j];
        P.row(6 * f + 3 + j) = top[j];
      }
    }
  });
  if (stats) {
    *stats = CurvaturePrismStats{};
    counts.combine_each([&](const CurvaturePrismStats& c) {
      stats->clamped += c.clamped;
      stats->limited += c.limited;
    });
  }
  return P;
}

PrismCorners curvature_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta,
                              double s_min, double s_max, int* clamped) {
  check_curvature_clamp(s_min, s_max);
  CurvaturePrismStats stats;
  PrismCorners P = curvature_prisms(V, F, face_curvature(V, F), eta, s_min, s_max, &stats);
  if (clamped) *clamped = stats.clamped;
  return P;
}

} // namespace gshell
