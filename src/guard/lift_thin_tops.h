#pragma once
// After the repair: top vertices left thinner than the paper's top are lifted one at a time by
// exactly checked moves that lower the shell energy E (docs/guarded-generation.md, "Lifting thin
// tops"). The repair cannot do it where a top lies within 1e-4 of its offset from the base: those
// vertices and their neighbours are held (the contact step bound cannot resolve pairs that close
// in floating point), yet many of them have room to rise once the repair has moved the rest.
#include "guard/start_check.h"

#include <gshell/solver/rest_tets.h>

#include <Eigen/Core>
#include <vector>

namespace gshell::detail {

struct LiftResult {
  int candidates = 0;      ///< top vertices thinner than kThinFraction of their wanted offset
  int lifted = 0;          ///< moves kept (a vertex may move in several sweeps)
  int checks = 0;          ///< exact checks run
  double energy_drop = 0;  ///< E before minus E after (>= 0)
};

/// Lifts the top (n x 3, valid for `checker`) of the shell over base (V, F) towards the wanted top
/// `wanted` (the paper's result): for every vertex with movable[i] thinner than 0.9 of its
/// wanted offset, the moves from the current top towards wanted_i, from the base towards
/// wanted_i, and along the extrusion direction d_i (at 1, 1/2, ..., 1/32 of the way or of
/// the wanted offset's length) are tried, the lowest-energy one that lowers the energy of the
/// vertex's tets first. Vertices move in groups that share no face, so that the energy of every
/// group falls by the sum of its members' drops; each group is checked exactly (checker.check
/// on the moved vertices) and its violators put back until none is left. So the top stays
/// valid for `checker` and E never rises. `ideal` are the rest tets of build_prism_tets(F, n).
LiftResult lift_thin_tops(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const RestTets& ideal,
                          const Eigen::MatrixXd& wanted, const Eigen::MatrixXd& directions,
                          const std::vector<char>& movable, const StartChecker& checker, int sweeps,
                          Eigen::MatrixXd& top);

} // namespace gshell::detail
