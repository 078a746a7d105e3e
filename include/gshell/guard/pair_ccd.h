#pragma once
// Conservative continuous collision detection of one pair in linear motion x_k + t dx_k: how far
// along the motion its distance provably stays above a floor (docs/contact.md).
//
// The method is conservative advancement with the relative-displacement bound of additive CCD
// (Li, Kaufman, Jiang 2021): with a common displacement c removed, every point of the first
// primitive moves at most max_i |dx_i - c| per unit t and every point of the second at most
// max_j |dx_j - c|, so the distance d(t) falls at most at their sum l. From a time t_k at which
// d(t_k) is measured, d stays >= floor on [t_k, t_k + (d(t_k) - floor) / l]; stepping to the end
// of that interval and measuring again advances a certified interval [0, t_k] that never contains
// a time below the floor. Only distances are evaluated (no polynomial roots), so grazing,
// parallel and touching-at-the-end motions need no special case; measured distances are lowered
// by a bound of their rounding error.
#include <gshell/guard/primitive_distance.h>

namespace gshell {

struct PairCcdOptions {
  /// The floor is keep_fraction * min(d(0), max_floor_distance).
  double keep_fraction = 0.1;
  double max_floor_distance = 1e300;
  /// Measurements before giving up (the bound is then the certified time so far): only motions
  /// that mostly slide past each other need many.
  int max_iterations = 256;
};

/// The largest t in [0, t_max] this method certifies: along x + s dx, 0 <= s <= t, the pair's
/// distance stays >= the floor. Conservative: the true largest such t is never smaller. A pair
/// that touches at x (or is within rounding of touching) gets 0 unless it does not move relative
/// to itself; one without relative motion gets t_max.
double pair_step_bound(PairKind kind, const PairPoints& x, const PairPoints& dx, double t_max,
                       const PairCcdOptions& options = {});

/// Whether the pair at x is so close (within ten times the rounding allowance of its measured
/// distance) that pair_step_bound certifies next to no relative motion of it: it touches as far
/// as floating point can tell. A guard that starts from such a state (a rest shell whose top was
/// left a hair's breadth from its base) leaves the pair out, as it does pairs that intersect.
bool pair_touches_to_rounding(PairKind kind, const PairPoints& x);

} // namespace gshell
