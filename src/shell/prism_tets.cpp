#include <gshell/shell/prism_tets.h>

#include "geometry/first_touch.h"
#include "quality/check_mesh_input.h"

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/shell/ideal_prisms.h>

#include <Eigen/Dense>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

namespace gshell {

std::array<std::array<int, 4>, 3> prism_corner_tets(int v0, int v1, int v2) {
  const std::array<int, 3> ids{v0, v1, v2};
  std::array<int, 3> order{0, 1, 2}; // face corners sorted by global id: a < b < c
  std::sort(order.begin(), order.end(), [&](int i, int j) { return ids[i] < ids[j]; });
  const int a = order[0], b = order[1], c = order[2];
  const int at = a + 3, bt = b + 3, ct = c + 3;
  std::array<std::array<int, 4>, 3> tets{{{a, b, c, ct}, {a, b, ct, bt}, {a, at, bt, ct}}};
  // (a,b,c) runs counter-clockwise iff it is a cyclic shift of the face order (0,1,2); otherwise
  // each tet would come out negative, so swap two of its vertices.
  const bool even = (b == (a + 1) % 3);
  if (!even)
    for (auto& t : tets) std::swap(t[2], t[3]);
  return tets;
}

Eigen::MatrixXi prism_tet_corners(const Eigen::MatrixXi& F) {
  if (F.rows() > 0 && F.cols() != 3) throw InputError("prism_tet_corners: faces must be m x 3");
  Eigen::MatrixXi C(3 * F.rows(), 4);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows(), 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index f = r.begin(); f != r.end(); ++f) {
      const auto tets = prism_corner_tets(F(f, 0), F(f, 1), F(f, 2));
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 4; ++j) C(3 * f + k, j) = tets[k][j];
    }
  });
  return C;
}

Eigen::MatrixXi build_prism_tets(const Eigen::MatrixXi& F, int n) {
  detail::check_face_indices(F, n, "build_prism_tets");
  Eigen::MatrixXi T(3 * F.rows(), 4);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows(), 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index f = r.begin(); f != r.end(); ++f) {
      const auto tets = prism_corner_tets(F(f, 0), F(f, 1), F(f, 2));
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 4; ++j) {
          const int corner = tets[k][j];
          T(3 * f + k, j) = corner < 3 ? F(f, corner) : n + F(f, corner - 3);
        }
    }
  });
  return T;
}

RestTets prism_rest_tets(const Eigen::MatrixXi& F, int n, const Eigen::MatrixXd& prisms) {
  if (prisms.rows() != 6 * F.rows() || prisms.cols() != 3)
    throw InputError("prism_rest_tets: expected " + std::to_string(6 * F.rows()) + " x 3 prism corners");
  // Corners taken per tet, in parallel (no 4K x 3 corner matrix: at millions of faces it was the
  // largest temporary of generation's setup, filled in a serial pass).
  return rest_tets_from_corner_function(build_prism_tets(F, n), [&](Eigen::Index t, const std::array<int, 4>&, TetCorners& U) {
    const Eigen::Index f = t / 3;
    const auto corners = prism_corner_tets(F(f, 0), F(f, 1), F(f, 2))[t % 3];
    for (int j = 0; j < 4; ++j) U.row(j) = prisms.row(6 * f + corners[j]);
  });
}

RestTets normal_prism_rest_tets(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta) {
  if (V.rows() > 0 && V.cols() != 3) throw InputError("normal_prism_rest_tets: V must be n x 3");
  detail::check_face_indices(F, V.rows(), "normal_prism_rest_tets");
  if (!std::isfinite(eta)) throw InputError("normal_prism_rest_tets: eta must be finite");
  RestTets rest;
  rest.T = build_prism_tets(F, static_cast<int>(V.rows()));
  const Eigen::Index m = F.rows();
  rest.volume.resize(3 * m);
  rest.prism_inverse.resize(m);
  detail::assign_populated(rest.unit_corners, 3 * m);
  // TBB rethrows a tet's InputError in this thread.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, m, 4096), [&](const tbb::blocked_range<Eigen::Index>& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      Eigen::Matrix3d B;
      B << b - a, c - a, normal_prism_lift(a, b, c, eta);
      const double det = B.determinant();
      rest.prism_inverse[f] = B.inverse();
      const bool invertible = rest.prism_inverse[f].allFinite();
      const auto tets = prism_corner_tets(F(f, 0), F(f, 1), F(f, 2));
      for (int i = 0; i < 3; ++i) {
        const Eigen::Index t = 3 * f + i;
        rest.unit_corners[t] = unit_corner_code(tets[i]);
        const double volume = det * unit_corner_determinant(rest.unit_corners[t]) / 6;
        if (!(volume > 0) || !std::isfinite(volume) || !invertible)
          throw InputError("face " + std::to_string(f) + " has zero area (its prism's tet " + std::to_string(t) +
                           " has volume " + format_number(volume) + ")"); // a caller knows faces, not tets
        rest.volume[t] = volume;
      }
    }
  });
  return rest;
}

} // namespace gshell
