#include <gshell/solver/rest_tets.h>

#include <gshell/error.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <string>

namespace gshell {

namespace {

// Fills tet t's rest data from its four rest corners; rejects flat or inverted rest shapes
// because the energy divides by them.
void set_rest_shape(RestTets& rest, Eigen::Index t, const Eigen::Vector3d& u0, const Eigen::Vector3d& u1,
                    const Eigen::Vector3d& u2, const Eigen::Vector3d& u3) {
  Eigen::Matrix3d Dm;
  Dm << u1 - u0, u2 - u0, u3 - u0;
  const double det = Dm.determinant();
  if (!(det > 0) || !std::isfinite(det))
    throw InputError("rest tet " + std::to_string(t) + " has non-positive volume (" + std::to_string(det / 6) +
                     ")");
  rest.Dm_inv[t] = Dm.inverse();
  rest.volume[t] = det / 6;
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
  return Dm_inv.empty() && unit_corners.size() == K && 3 * prism_inverse.size() == K;
}

Eigen::Matrix3d RestTets::dm_inv(Eigen::Index t) const {
  if (!Dm_inv.empty()) return Dm_inv[t];
  Eigen::Matrix3d D;
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
    set_rest_shape(rest, t, X.row(T(t, 0)).transpose(), X.row(T(t, 1)).transpose(), X.row(T(t, 2)).transpose(),
                   X.row(T(t, 3)).transpose());
  }
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
      set_rest_shape(rest, t, U.row(0).transpose(), U.row(1).transpose(), U.row(2).transpose(), U.row(3).transpose());
    }
  });
  return rest;
}

} // namespace gshell
