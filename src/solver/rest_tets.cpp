#include <gshell/solver/rest_tets.h>

#include <gshell/error.h>
#include <gshell/format_number.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <string>

namespace gshell {

namespace {

// Tet t's rest volume from its four rest corners; rejects flat or inverted rest shapes because
// the energy divides by them. Eigen's determinant, as before the positions form existed (the
// inverse's own determinant may differ from it in the last bit).
double checked_rest_volume(Eigen::Index t, const double* u0, const double* u1, const double* u2, const double* u3) {
  Eigen::Matrix3d Dm;
  for (int r = 0; r < 3; ++r) {
    Dm(r, 0) = u1[r] - u0[r];
    Dm(r, 1) = u2[r] - u0[r];
    Dm(r, 2) = u3[r] - u0[r];
  }
  const double det = Dm.determinant();
  if (!(det > 0) || !std::isfinite(det))
    throw InputError("rest tet " + std::to_string(t) + " has non-positive volume (" + format_number(det / 6) + ")");
  return det / 6;
}

// The same, and the tet's inverse edge matrix into out (column-major).
double checked_rest_shape(Eigen::Index t, const double* u0, const double* u1, const double* u2, const double* u3,
                          double* out) {
  const double volume = checked_rest_volume(t, u0, u1, u2, u3);
  detail::inverse_edge_matrix(u0, u1, u2, u3, out);
  return volume;
}

void set_rest_shape(RestTets& rest, Eigen::Index t, const TetCorners& U) {
  rest.volume[t] = checked_rest_shape(t, U.row(0).data(), U.row(1).data(), U.row(2).data(), U.row(3).data(),
                                      rest.Dm_inv[t].data());
}

// Corner c of the unit prism: base (0,0,0), (1,0,0), (0,1,0), tops those + (0,0,1).
Eigen::Vector3d unit_prism_corner(int c) { return {c % 3 == 1 ? 1.0 : 0.0, c % 3 == 2 ? 1.0 : 0.0, c >= 3 ? 1.0 : 0.0}; }

constexpr int kUnitCornerCodes = 6 * 6 * 6 * 6;

struct UnitCornerTable {
  std::array<Eigen::Matrix3d, kUnitCornerCodes> inverse;
  std::array<double, kUnitCornerCodes> determinant;
  UnitCornerTable() {
    for (int code = 0; code < kUnitCornerCodes; ++code) {
      const int c0 = code % 6, c1 = code / 6 % 6, c2 = code / 36 % 6, c3 = code / 216;
      Eigen::Matrix3d C;
      C << unit_prism_corner(c1) - unit_prism_corner(c0), unit_prism_corner(c2) - unit_prism_corner(c0),
          unit_prism_corner(c3) - unit_prism_corner(c0);
      determinant[code] = C.determinant(); // integer entries: exact
      // |det C| is 0 or 1 (no tet of the unit prism is bigger than a sixth of a unit cube), so the
      // inverse has integer entries and is exact too.
      inverse[code] = determinant[code] != 0 ? Eigen::Matrix3d(C.inverse()) : Eigen::Matrix3d::Zero();
    }
  }
};

const UnitCornerTable& unit_corner_table() {
  static const UnitCornerTable table;
  return table;
}

} // namespace

bool RestTets::complete() const {
  const std::size_t K = static_cast<std::size_t>(size());
  if (static_cast<std::size_t>(volume.size()) != K) return false;
  if (Dm_inv.size() == K) return true;
  if (!Dm_inv.empty()) return false;
  if (!rest_points.empty()) {
    // The local step reads points by tet id and finds overrides by binary search: check both.
    const std::size_t points = rest_points.size() / 3;
    return rest_points.size() % 3 == 0 && (K == 0 || (T.minCoeff() >= 0 && static_cast<std::size_t>(T.maxCoeff()) < points)) &&
           override_tets.size() == override_Dm_inv.size() &&
           std::is_sorted(override_tets.begin(), override_tets.end()) &&
           (override_tets.empty() || (override_tets.front() >= 0 && static_cast<std::size_t>(override_tets.back()) < K));
  }
  return unit_corners.size() == K && 3 * prism_inverse.size() == K;
}

Eigen::Matrix3d RestTets::dm_inv(Eigen::Index t) const {
  if (!Dm_inv.empty()) return Dm_inv[t];
  Eigen::Matrix3d D;
  if (!rest_points.empty()) {
    detail::positions_form_dm_inv(rest_points.data(), T.data(), T.rows(), override_tets.data(), override_tets.size(),
                                  override_Dm_inv.empty() ? nullptr : override_Dm_inv[0].data(), t, D.data());
    return D;
  }
  detail::multiply_3x3(unit_corner_inverses()[unit_corners[t]].data(), prism_inverse[t / 3].data(), D.data());
  return D;
}

std::uint16_t unit_corner_code(const std::array<int, 4>& corners) {
  int code = 0;
  for (int j = 3; j >= 0; --j) {
    if (corners[j] < 0 || corners[j] >= 6)
      throw InputError("unit_corner_code: prism corner " + std::to_string(corners[j]) + " is outside [0, 6)");
    code = 6 * code + corners[j];
  }
  return static_cast<std::uint16_t>(code);
}

const Eigen::Matrix3d* unit_corner_inverses() { return unit_corner_table().inverse.data(); }

double unit_corner_determinant(std::uint16_t code) { return unit_corner_table().determinant.at(code); }

RestTets rest_tets_from_positions(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T) {
  if (X.cols() != 3 || T.cols() != 4)
    throw InputError("rest_tets_from_positions: expected N x 3 positions and K x 4 tets (got " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()) + " and " + std::to_string(T.rows()) +
                     " x " + std::to_string(T.cols()) + ")");
  RestTets rest;
  rest.T = T;
  rest.Dm_inv.resize(T.rows());
  rest.volume.resize(T.rows());
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    for (int j = 0; j < 4; ++j)
      if (T(t, j) < 0 || T(t, j) >= X.rows())
        throw InputError("tet " + std::to_string(t) + " has vertex id " + std::to_string(T(t, j)) +
                         " out of range");
    TetCorners U;
    for (int j = 0; j < 4; ++j) U.row(j) = X.row(T(t, j));
    set_rest_shape(rest, t, U);
  }
  return rest;
}

RestTets rest_tets_in_positions_form(const Eigen::MatrixXd& X, Eigen::MatrixXi T,
                                     const std::function<bool(Eigen::Index, const std::array<int, 4>&, TetCorners&)>& replace) {
  if (X.cols() != 3 || T.cols() != 4)
    throw InputError("rest_tets_in_positions_form: expected N x 3 positions and K x 4 tets (got " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()) + " and " + std::to_string(T.rows()) +
                     " x " + std::to_string(T.cols()) + ")");
  if (!X.allFinite()) throw InputError("rest_tets_in_positions_form: a rest position is not finite");
  RestTets rest;
  rest.T = std::move(T);
  const Eigen::Index K = rest.T.rows(), N = X.rows();
  rest.rest_points.resize(3 * static_cast<std::size_t>(N));
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(rest.rest_points.data(), N, 3) = X;
  rest.volume.resize(K);
  // Whether each tet was replaced: its matrix is made again afterwards, in order, so that the
  // override list comes out sorted without a concurrent container.
  std::vector<std::uint8_t> replaced(replace ? K : 0, 0);
  const auto corners_of = [&](Eigen::Index t, std::array<int, 4>& ids, TetCorners& U) {
    for (int j = 0; j < 4; ++j) {
      ids[j] = rest.T(t, j);
      if (ids[j] < 0 || ids[j] >= N)
        throw InputError("tet " + std::to_string(t) + " has vertex id " + std::to_string(ids[j]) + " out of range");
      U.row(j) = X.row(ids[j]);
    }
    return replace && replace(t, ids, U);
  };
  // TBB rethrows a tet's InputError in this thread.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, K, 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
    TetCorners U;
    std::array<int, 4> ids;
    for (Eigen::Index t = r.begin(); t != r.end(); ++t) { // the inverses are made where they are read
      if (corners_of(t, ids, U)) replaced[t] = 1;
      rest.volume[t] = checked_rest_volume(t, U.row(0).data(), U.row(1).data(), U.row(2).data(), U.row(3).data());
    }
  });
  for (Eigen::Index t = 0; t < static_cast<Eigen::Index>(replaced.size()); ++t) {
    if (!replaced[t]) continue;
    TetCorners U;
    std::array<int, 4> ids;
    corners_of(t, ids, U);
    rest.override_tets.push_back(static_cast<int>(t));
    rest.override_Dm_inv.emplace_back();
    checked_rest_shape(t, U.row(0).data(), U.row(1).data(), U.row(2).data(), U.row(3).data(),
                       rest.override_Dm_inv.back().data());
  }
  return rest;
}

RestTets with_matrix_per_tet(RestTets rest) {
  if (static_cast<Eigen::Index>(rest.Dm_inv.size()) == rest.size()) return rest;
  std::vector<Eigen::Matrix3d> matrices(static_cast<std::size_t>(rest.size()));
  tbb::parallel_for(tbb::blocked_range<int>(0, rest.size(), 4096), [&](const tbb::blocked_range<int>& r) {
    for (int t = r.begin(); t != r.end(); ++t) matrices[t] = rest.dm_inv(t);
  });
  rest.Dm_inv = std::move(matrices);
  rest.rest_points = {};
  rest.override_Dm_inv = {};
  rest.prism_inverse = {};
  rest.unit_corners = {};
  return rest;
}

RestTets rest_tets_from_corners(const Eigen::MatrixXi& T, const Eigen::MatrixXd& corners) {
  if (T.cols() != 4) throw InputError("rest_tets_from_corners: expected K x 4 tets");
  if (corners.rows() != 4 * T.rows() || corners.cols() != 3)
    throw InputError("rest_tets_from_corners: expected " + std::to_string(4 * T.rows()) + " x 3 corners");
  return rest_tets_from_corner_function(T, [&](Eigen::Index t, const std::array<int, 4>&, TetCorners& U) { U = corners.middleRows(4 * t, 4); });
}

RestTets rest_tets_from_corner_function(Eigen::MatrixXi T,
                                        const std::function<void(Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U)>& corners) {
  if (T.cols() != 4) throw InputError("rest_tets_from_corners: expected K x 4 tets");
  RestTets rest;
  rest.T = std::move(T);
  rest.Dm_inv.resize(rest.T.rows());
  rest.volume.resize(rest.T.rows());
  // TBB rethrows a tet's InputError in this thread.
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, rest.T.rows(), 1024), [&](const tbb::blocked_range<Eigen::Index>& r) {
    TetCorners U;
    std::array<int, 4> ids;
    for (Eigen::Index t = r.begin(); t != r.end(); ++t) {
      for (int j = 0; j < 4; ++j) ids[j] = rest.T(t, j);
      corners(t, ids, U);
      set_rest_shape(rest, t, U);
    }
  });
  return rest;
}

} // namespace gshell
