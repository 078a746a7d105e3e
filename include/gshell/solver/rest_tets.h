#pragma once
// Per-tet rest shapes for the deformation energy (docs/design.md "The energy").
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace gshell {

/// Rest shapes of K tets over a vertex set. Each tet has its own rest shape, so "cracked"
/// ideal prisms and a seamless rest shell are the same data.
///
/// The inverse rest edge matrices come in one of two forms; read them with dm_inv(t):
/// - per tet (`Dm_inv`, K matrices), any rest shapes;
/// - the affine-prism form (`Dm_inv` empty): tets 3p..3p+2 are cut from prism p, an affine image
///   x = x_0 + B_p c of the unit prism (base corners c = (0,0,0), (1,0,0), (0,1,0), top corners
///   those + (0,0,1)), as generation's normal prisms are. Tet t's edge matrix is then B_p C_t,
///   with C_t the edge matrix of its corners in the unit prism, so its inverse is C_t^-1 B_p^-1:
///   one matrix per prism and a corner code per tet, 26 bytes per tet instead of 72 (0.7 GB less
///   at 15.7M tets, where the per-tet matrices were the largest buffer of a generation).
struct RestTets {
  Eigen::MatrixXi T;                       ///< K x 4 global vertex ids
  std::vector<Eigen::Matrix3d> Dm_inv;     ///< per tet [u1-u0, u2-u0, u3-u0]^-1, or empty (prism form)
  Eigen::VectorXd volume;                  ///< rest volumes (> 0), per tet in both forms
  std::vector<Eigen::Matrix3d> prism_inverse; ///< prism form: per prism, B_p^-1
  std::vector<std::uint16_t> unit_corners; ///< prism form: per tet, unit_corner_code of its corners
  int size() const { return static_cast<int>(T.rows()); }
  /// Whether every tet has its rest shape (in either form) and its volume.
  bool complete() const;
  /// Tet t's inverse rest edge matrix (0 <= t < size(); no check).
  Eigen::Matrix3d dm_inv(Eigen::Index t) const;
};

namespace detail {
/// out = C B for column-major 3x3 arrays, each entry summed in the same order wherever it is
/// used, so that RestTets::dm_inv and the solver's local step give the same bits.
inline void multiply_3x3(const double* C, const double* B, double* out) {
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) out[k + 3 * c] = C[k] * B[3 * c] + C[k + 3] * B[1 + 3 * c] + C[k + 6] * B[2 + 3 * c];
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

/// Rest shapes given per tet corner: corners is 4K x 3, rows 4t..4t+3 the rest positions of tet
/// t's vertices T(t,0..3).
/// \throws InputError when T is not K x 4, corners not 4K x 3, or a tet has non-positive (or
///         non-finite) rest volume.
RestTets rest_tets_from_corners(const Eigen::MatrixXi& T, const Eigen::MatrixXd& corners);

/// Row j of a tet's 4 x 3 rest corners: the rest position of its vertex T(t, j).
using TetCorners = Eigen::Matrix<double, 4, 3, Eigen::RowMajor>;

/// The same with the corners made per tet by `corners(t, ids, U)` (ids = row t of T; called
/// concurrently for different t), so that no 4K x 3 corner matrix is held: at millions of tets it would be the largest
/// temporary of the setup.
/// \throws InputError when T is not K x 4 or a tet has non-positive (or non-finite) rest volume;
///         whatever `corners` throws.
RestTets rest_tets_from_corner_function(Eigen::MatrixXi T,
                                        const std::function<void(Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U)>& corners);

} // namespace gshell
