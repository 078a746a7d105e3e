#pragma once
// Per-tet rest shapes for the deformation energy (docs/design.md "The energy").
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace gshell {

/// Row j of a tet's 4 x 3 rest corners: the rest position of its vertex T(t, j).
using TetCorners = Eigen::Matrix<double, 4, 3, Eigen::RowMajor>;

/// Rest shapes of K tets over a vertex set. Each tet has its own rest shape, so "cracked"
/// ideal prisms and a seamless rest shell are the same data.
///
/// The inverse rest edge matrices come in one of three forms; read them with dm_inv(t):
/// - per tet (`Dm_inv`, K matrices), any rest shapes;
/// - the positions form (`rest_points` not empty): a tet's rest corners are its own vertices' rest
///   positions, and its inverse is recomputed from them where it is read (inverse_edge_matrix),
///   except for the few tets listed in `override_tets`, which keep a matrix of their own. 8 bytes
///   per tet instead of 72 (plus 24 per vertex): the deformer's rest shell is not made of affine
///   prisms, and at 15.7M tets its per-tet matrices were 1.1 GB;
/// - the affine-prism form (`Dm_inv` empty): tets 3p..3p+2 are cut from prism p, an affine image
///   x = x_0 + B_p c of the unit prism (base corners c = (0,0,0), (1,0,0), (0,1,0), top corners
///   those + (0,0,1)), as generation's normal prisms are. Tet t's edge matrix is then B_p C_t,
///   with C_t the edge matrix of its corners in the unit prism, so its inverse is C_t^-1 B_p^-1:
///   one matrix per prism and a corner code per tet, 26 bytes per tet instead of 72 (0.7 GB less
///   at 15.7M tets, where the per-tet matrices were the largest buffer of a generation).
struct RestTets {
  Eigen::MatrixXi T;                       ///< K x 4 global vertex ids
  std::vector<Eigen::Matrix3d> Dm_inv;     ///< per tet [u1-u0, u2-u0, u3-u0]^-1, or empty (other forms)
  Eigen::VectorXd volume;                  ///< rest volumes (> 0), per tet in every form
  std::vector<Eigen::Matrix3d> prism_inverse; ///< prism form: per prism, B_p^-1
  std::vector<std::uint16_t> unit_corners; ///< prism form: per tet, unit_corner_code of its corners
  std::vector<double> rest_points;         ///< positions form: N x 3 rest positions, row-major
  /// Tets whose rest shape is not their vertices' rest positions', ascending: in the positions
  /// form those with a matrix in override_Dm_inv; kept by with_matrix_per_tet as a record (the
  /// hierarchical solver's levels read it).
  std::vector<int> override_tets;
  std::vector<Eigen::Matrix3d> override_Dm_inv; ///< positions form: their inverse edge matrices
  int size() const { return static_cast<int>(T.rows()); }
  /// Whether every tet has its rest shape (in one of the forms) and its volume; in the positions
  /// form also that every tet's vertices have rest points and the overrides are ascending.
  bool complete() const;
  /// Tet t's inverse rest edge matrix (0 <= t < size(); no check).
  Eigen::Matrix3d dm_inv(Eigen::Index t) const;
};

namespace detail {
/// out = C B for column-major 3x3 arrays, each entry summed in the same order wherever it is
/// used, so that RestTets::dm_inv and the solver's local step agree to rounding (the local step's
/// AVX2/AVX-512 variants may fuse a multiply and an add: GCC contracts by default in C++).
inline void multiply_3x3(const double* C, const double* B, double* out) {
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) out[k + 3 * c] = C[k] * B[3 * c] + C[k + 3] * B[1 + 3 * c] + C[k + 6] * B[2 + 3 * c];
}

/// out = [x1 - x0, x2 - x0, x3 - x0]^-1 (column-major) for the points x0..x3 (3 doubles each),
/// by cofactors in Eigen's order for 3x3 inverses (the same bits as Eigen's inverse, in code
/// compiled without FMA); returns the determinant of the edge matrix. Shared by every form and the
/// solver's local step. The caller checks the determinant (zero or not finite: no inverse).
inline double inverse_edge_matrix(const double* x0, const double* x1, const double* x2, const double* x3, double* out) {
  double m[9]; // column-major edge matrix
  for (int r = 0; r < 3; ++r) {
    m[r] = x1[r] - x0[r];
    m[r + 3] = x2[r] - x0[r];
    m[r + 6] = x3[r] - x0[r];
  }
  auto at = [&](int r, int c) { return m[r + 3 * c]; };
  // cofactor(i, j) of m, as the (j, i) entry of the adjugate
  auto cofactor = [&](int i, int j) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
    return at(i1, j1) * at(i2, j2) - at(i1, j2) * at(i2, j1);
  };
  const double c0 = cofactor(0, 0), c1 = cofactor(1, 0), c2 = cofactor(2, 0);
  const double det = c0 * at(0, 0) + c1 * at(1, 0) + c2 * at(2, 0);
  const double inv_det = 1.0 / det;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[j + 3 * i] = (j == 0 ? (i == 0 ? c0 : i == 1 ? c1 : c2) : cofactor(i, j)) * inv_det;
  return det;
}

/// Tet t's inverse edge matrix in the positions form (out: column-major): its override if it has
/// one, else made from its vertices' rest positions. points: N x 3 row-major; T: K x 4
/// column-major; override_tets ascending, override_inv their matrices (9 doubles each).
inline void positions_form_dm_inv(const double* points, const int* T, std::ptrdiff_t K, const int* override_tets,
                                  std::size_t overrides, const double* override_inv, std::ptrdiff_t t, double* out) {
  if (overrides > 0) {
    const int* end = override_tets + overrides;
    const int* it = std::lower_bound(override_tets, end, static_cast<int>(t));
    if (it != end && *it == t) {
      std::copy_n(override_inv + 9 * (it - override_tets), 9, out);
      return;
    }
  }
  const int* v = T + t;
  inverse_edge_matrix(points + 3 * static_cast<std::ptrdiff_t>(v[0]), points + 3 * static_cast<std::ptrdiff_t>(v[K]),
                      points + 3 * static_cast<std::ptrdiff_t>(v[2 * K]), points + 3 * static_cast<std::ptrdiff_t>(v[3 * K]),
                      out);
}
} // namespace detail

/// Code of a tet of the unit prism given as its corners (0..2 base, 3..5 the tops above them):
/// c0 + 6 c1 + 36 c2 + 216 c3.
/// \throws InputError when a corner is outside [0, 6).
std::uint16_t unit_corner_code(const std::array<int, 4>& corners);
/// C^-1 for every code (1296 matrices, column-major, contiguous); zero for corner sets that span
/// no volume. unit_corner_inverses()[code] is the inverse edge matrix of that tet of the unit
/// prism.
const Eigen::Matrix3d* unit_corner_inverses();
/// det C for every code (+1 or -1 for the tets a prism is cut into, 0 for flat corner sets).
double unit_corner_determinant(std::uint16_t code);

/// Rest shapes taken from positions X (N x 3) of the tets T itself (deformation: the rest shell).
/// \throws InputError when X is not N x 3, T not K x 4, a tet id is outside [0, N) or a tet has
///         non-positive (or non-finite) rest volume.
RestTets rest_tets_from_positions(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T);

/// Rest shapes in the positions form: tet t's rest corners are the rows T(t, .) of X, unless
/// `replace(t, ids, U)` (U holding those rows; called concurrently for different t, and once more
/// for each tet it replaced) puts other corners in U and returns true: that tet then keeps their
/// inverse in override_Dm_inv. dm_inv(t) gives the same bits as the per-tet form of the same shapes.
/// \throws InputError when X is not N x 3 or not finite, T not K x 4, a tet id is outside [0, N)
///         or a tet has non-positive (or non-finite) rest volume; whatever `replace` throws.
RestTets rest_tets_in_positions_form(
    const Eigen::MatrixXd& X, Eigen::MatrixXi T,
    const std::function<bool(Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U)>& replace = {});

/// The same shapes in the per-tet form (one inverse matrix per tet, the same bits as dm_inv(t)),
/// override_tets kept: 72 bytes per tet, and the local step reads a matrix faster than it remakes
/// it from the positions (about 10% of a pose on the bench_pose bowl). Any form in.
RestTets with_matrix_per_tet(RestTets rest);

/// Rest shapes given per tet corner: corners is 4K x 3, rows 4t..4t+3 the rest positions of tet
/// t's vertices T(t,0..3).
/// \throws InputError when T is not K x 4, corners not 4K x 3, or a tet has non-positive (or
///         non-finite) rest volume.
RestTets rest_tets_from_corners(const Eigen::MatrixXi& T, const Eigen::MatrixXd& corners);

/// The same with the corners made per tet by `corners(t, ids, U)` (ids = row t of T; called
/// concurrently for different t), so that no 4K x 3 corner matrix is held: at millions of tets it would be the largest
/// temporary of the setup.
/// \throws InputError when T is not K x 4 or a tet has non-positive (or non-finite) rest volume;
///         whatever `corners` throws.
RestTets rest_tets_from_corner_function(Eigen::MatrixXi T,
                                        const std::function<void(Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U)>& corners);

} // namespace gshell
