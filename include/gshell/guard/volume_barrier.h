#pragma once
// A barrier against flat and inverted tets: zero while a tet keeps a healthy volume, growing
// without bound as its volume goes to zero. With J_t = det F_t (current volume over rest volume):
//   B(X) = sum_t vol_t psi(J_t / j_hat),   psi(u) = -(u - 1)^2 log(u) for 0 < u < 1, 0 for u >= 1,
// +infinity as soon as a guarded tet has J_t <= 0. psi is C^2 at u = 1 (the IPC barrier shape), so
// tets with J_t >= j_hat see none of it: only tets near collapse are touched.
#include <gshell/solver/rest_tets.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace gshell {

class VolumeBarrier {
public:
  /// `rest`: the tets and their rest shapes (rest volumes weight the terms, so B has the units of
  /// the shell energy). j_hat in (0, 1]: the relative volume below which a tet is pushed back.
  /// `skip` (empty or one flag per tet): tets left out (e.g. prisms around unextrudable vertices).
  /// \throws InputError when j_hat is outside (0, 1] or skip has neither 0 nor one flag per tet.
  /// The evaluations below do not check X (they run in every solver iteration): it must hold every
  /// row the tets use.
  VolumeBarrier(const RestTets& rest, double j_hat, std::vector<char> skip = {});

  /// B at X (2n x 3 shell positions); +infinity if a guarded tet is flat or inverted (by the exact
  /// orientation sign wherever the barrier acts, so a tet that rounding shows with a tiny positive
  /// J but that the certificate finds flat or inverted is outside the domain too). With
  /// `active`, also the tets where the barrier acts (0 < J < j_hat), ascending.
  double energy(const Eigen::MatrixXd& X, std::vector<int>* active = nullptr) const;
  /// G += scale * dB/dX, summed over `active` (the list energy() gave at this X).
  void add_gradient(const Eigen::MatrixXd& X, double scale, Eigen::MatrixXd& G, const std::vector<int>& active) const;
  /// Appends scale * H over `active` (the list energy() gave at this X; a tet of it that is not
  /// inside the barrier at X adds a block of zeros) as 144 triplets per tet, in the order of
  /// `active`, indexed 3 * vertex + axis, H positive
  /// semi-definite: with `projected` false the Gauss-Newton part of d^2B/dX^2 (vol psi'' grad J
  /// grad J^T per tet); with `projected` true each tet's whole Hessian, psi'' grad J grad J^T +
  /// psi' d^2J, projected onto its positive eigenvalues (in the space of the tet's three edges).
  /// The Gauss-Newton part does not see that turning a nearly flat tet further flat (a motion
  /// orthogonal to grad J) lowers J at second order, and psi' ~ -1/J makes that term dominant
  /// there: a solver using it alone keeps squashing such tets, each step clamped by them.
  /// With `kept_vertices` (one flag per vertex), only the 3 x 3 blocks of two flagged vertices
  /// are appended, in the same order: a solver that drops the rows and columns of the vertices it
  /// holds (most tets of a shell have corners on its fixed base) need not receive them.
  /// \throws InputError when `kept_vertices` has not one flag per row of X.
  void add_hessian(const Eigen::MatrixXd& X, double scale, std::vector<Eigen::Triplet<double>>& H,
                   const std::vector<int>& active, bool projected = false,
                   const std::vector<char>* kept_vertices = nullptr) const;

  /// Tets with 0 < J < j_hat at X (where the barrier acts), ascending.
  std::vector<int> active_tets(const Eigen::MatrixXd& X) const;
  /// J of tet t at X and its gradient (4 corners).
  double relative_volume_gradient(const Eigen::MatrixXd& X, int t, Eigen::Vector3d grad[4]) const {
    return relative_volume(X, t, grad);
  }
  /// J of tet t at X.
  double relative_volume_of(const Eigen::MatrixXd& X, int t) const { return relative_volume(X, t, nullptr); }
  /// Smallest J over the guarded tets at X (+infinity if none).
  double min_relative_volume(const Eigen::MatrixXd& X) const;

  const std::vector<char>& skip() const { return skip_; }
  /// Other tets left out for the following evaluations (as `skip` of the constructor; e.g. a moving
  /// base whose unextrudable vertices change). \throws InputError when skip has neither 0 nor one
  /// flag per tet.
  void set_skip(std::vector<char> skip);
  double j_hat() const { return j_hat_; }
  /// Another j_hat (in (0, 1], else InputError) for the following evaluations.
  void set_j_hat(double j_hat);

private:
  // J of tet t at X and, if wanted, dJ/dx of its 4 corners.
  double relative_volume(const Eigen::MatrixXd& X, int t, Eigen::Vector3d* grad) const;
  // Whether tet t's exact orientation at X is positive (the certificate's test).
  bool positively_oriented(const Eigen::MatrixXd& X, int t) const;

  Eigen::MatrixXi T_;
  std::vector<double> inv_det_rest_; // det Dm_inv: J = det(D) * inv_det_rest
  std::vector<double> weight_;       // rest volumes
  std::vector<char> skip_;
  double j_hat_;
};

} // namespace gshell
