#pragma once
// The largest step along a motion that keeps every tet positively oriented (the flip-avoiding line
// search of Smith & Schaefer 2015): along X + s D the signed volume of a tet is a cubic in s, and
// the step stops before the first s where it falls to a fraction of its value at s = 0.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <array>
#include <vector>

namespace gshell {

/// Coefficients a0..a3 of 6 * signed volume of tet (x0, x1, x2, x3) moved along (d0..d3):
/// det[x1 - x0 + s (d1 - d0), x2 - x0 + s (d2 - d0), x3 - x0 + s (d3 - d0)] = a0 + a1 s + a2 s^2 + a3 s^3.
std::array<double, 4> tet_volume_cubic(const Eigen::Vector3d x[4], const Eigen::Vector3d d[4]);

/// The largest s in [0, max_step] with p(u) > keep * p(0) for all u in [0, s], p the cubic above
/// (p(0) > 0 and keep in [0, 1) assumed; a cubic that never falls that low gives max_step). The
/// root is bracketed on the cubic's monotone pieces and bisected to round-off, and the returned
/// step lies below it.
double cubic_step_bound(const std::array<double, 4>& a, double keep, double max_step);

struct TetStepBound {
  double step = 0; ///< the bound, in [0, max_step]
  int tet = -1;    ///< the tet that limits it (-1 if none does)
};

/// The largest s in [0, max_step] such that along X + u D, 0 <= u <= s, every tet of T (K x 4 rows
/// of X; positively oriented at X) keeps more than keep_fraction of its volume at X. Tets with
/// skip[t] != 0 (if skip is given, one flag per tet) and tets whose volume at X is not positive are
/// ignored. X, D: N x 3. Runs in parallel.
/// \throws InputError when X or D is not N x 3, T is not K x 4 with ids in 0..N-1, or skip has
///         other than K flags.
TetStepBound tet_step_bound(const Eigen::MatrixXi& T, const Eigen::MatrixXd& X, const Eigen::MatrixXd& D,
                            double keep_fraction, double max_step, const std::vector<char>* skip = nullptr);

/// Whether every tet of T that tet_step_bound would bound (positive at X0, not skipped) keeps more
/// than keep_fraction of its volume at X1: the condition of tet_step_bound at the end of the path
/// alone, whatever happens on the way (a rigid turn by more than 143 degrees keeps every volume at
/// its end while the straight path flattens tets half-way). X0, X1: N x 3. Runs in parallel.
/// \throws InputError as tet_step_bound.
bool tets_keep_volume(const Eigen::MatrixXi& T, const Eigen::MatrixXd& X0, const Eigen::MatrixXd& X1,
                      double keep_fraction, const std::vector<char>* skip = nullptr);

/// The tets whose own bound (as in tet_step_bound) is below max_step, in increasing order: those
/// that would cut a step of max_step. Same preconditions and errors as tet_step_bound.
std::vector<int> tets_cutting_step(const Eigen::MatrixXi& T, const Eigen::MatrixXd& X, const Eigen::MatrixXd& D,
                                   double keep_fraction, double max_step, const std::vector<char>* skip = nullptr);

} // namespace gshell
