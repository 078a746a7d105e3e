#pragma once
// The guarded solver: minimises the shell energy of ShellSolver (sum_t vol_t ||F_t - R_t||^2
// towards per-tet rest shapes) plus two barriers, from a valid state, so that every iterate stays
// valid: no tet turns flat or inverted, and no two primitives of the layer's boundary surface
// (shell_boundary: top, base, side walls) touch.
//
//   E_guard(X) = E(X) + volume_weight * VolumeBarrier(X) + contact_stiffness * ContactGuard::energy(X)
//
// Both barriers are zero away from trouble (tets above j_hat of their rest volume, pairs farther
// apart than dhat), so most of the shell sees E alone. Each iteration:
//  1. direction: the Newton step of the quadratic model with E's fixed-rotation Hessian (the
//     prefactored system matrix A of ShellSolver) plus the barriers' Hessians, solved by conjugate
//     gradients preconditioned with A^-1 and started from the plain local/global step -A^-1 g (so
//     without active barriers it is exactly the paper's iteration, and with them the few stiff
//     directions near contact are resolved in a few CG iterations: one near-contact spot does not
//     clamp the step of the whole shell);
//  2. step bound: the largest step keeping every tet above keep_fraction of its volume (per-tet
//     cubic, tet_step_bound) and every boundary pair farther apart than keep_fraction of its
//     distance (conservative CCD, ContactGuard::step_bound), capped at 1; when a few tets or
//     pairs cut it short, the step with their vertices held still may go further
//     (GuardedSolverParameters::hold_rounds);
//  3. backtracking line search from that step until E_guard decreases (Armijo), so the guarded
//     energy never rises;
// until the relative decrease of E_guard falls below the tolerance.
//
// Precompute once, solve many: the system matrix is factored and the contact structures built in
// the constructor, for a rest shape and a set of fixed vertices; solve() runs from any valid
// state. Fixed vertices may be moved along a straight path during a solve (a deformed base
// dragging its shell): each iteration first advances them along the path as far as the bounds
// allow, the free vertices following by the linear response of the model, then takes an energy
// step with them held. With contacts guarded the response is that of E_guard's quadratic model,
// -(A + H/2)_ff^-1 (A + H/2)_fc dX_c with H the barriers' Hessian (solved like the direction of
// step 1): free vertices near a contact are held apart while the fixed ones move (a plane folded
// shut: its top thins where the two halves press together) instead of being carried into the
// step bound, where the model's response alone (-A_ff^-1 A_fc dX_c, kept when only the tets are
// guarded) stalls. A contact-guarded drag that the bounds hold still (less than 0.1% of the path
// in 20 iterations: the fixed vertices force a contact) ends early with path_done < 1; so does a
// tets-only drag whose last 20 iterations went so little of the path that a hundred times their
// pace would not finish it in the iterations left.
#include <gshell/guard/contact_guard.h>
#include <gshell/guard/volume_barrier.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/solver/shell_solver.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <vector>

namespace gshell {

/// The barrier and step parameters of the guarded solver (absolute values; generation derives
/// them from the thickness, GenerateOptions::guard).
struct GuardedSolverParameters {
  double j_hat = 0.1;         ///< relative volume (det F) below which the volume barrier acts, (0, 1]
  double volume_weight = 1.0; ///< weight of the volume barrier (dimensionless: terms are vol_t psi)
  /// Contact barrier support dhat (model units); 0 disables contacts (tets are still guarded).
  double contact_distance = 0;
  /// Weight of the contact barrier (1 / model units: the barrier is in length^4, E in length^3).
  double contact_stiffness = 0;
  /// A step keeps every tet above this fraction of its volume and every boundary pair above this
  /// fraction of its distance at the start of the step, in (0, 1).
  double keep_fraction = 0.1;
  /// A step bound set by a few tets or pairs holds back the whole step. When a step is cut below
  /// hold_below, the free vertices of every tet and pair that would cut a step of min(0.5, 64 x
  /// the bound) are held still for it, again for those the holding makes cut it, up to
  /// hold_rounds rounds; that step is taken when its first-order decrease is larger. 0 rounds:
  /// every step is the cut one (generation: 4, docs/guarded-generation.md "Holding what cuts the
  /// step").
  int hold_rounds = 0;
  double hold_below = 0.05;
  /// Anderson acceleration (history length; 0 = off) of the iterations after the drag's path is
  /// done whose step is not cut: a step is the model's local/global iteration (corrected near the
  /// barriers that act), which creeps along soft modes, and the combined iterate is taken only
  /// when the bounds let all of it through and it lowers E_guard at least as the Armijo test asks
  /// of the plain step. A solve that takes one converges only once the plain step's predicted
  /// decrease is below the tolerance as well.
  int anderson_history = 0;
  /// Lengthened steps (largest multiple of the plain step tried; 0 or 1 = off). Once a drag's
  /// path is done and the solve has run 100 iterations from there, a plain step taken whole that
  /// lowered E_guard by at least 1.9x what the model predicts (E_guard nearly linear along it:
  /// the model, holding the rotations, takes a soft mode of the shell, a bending or twisting
  /// one, for stiff) is tried longer: at the power of two below the minimum of the quadratic
  /// fitted along it, halved until taken, then doubled while E_guard keeps falling; every longer
  /// step is bounded like any step. A solve with it on converges only once the plain step's
  /// predicted decrease is below the tolerance too: a single iteration's small decrease can be
  /// an unlucky step, not the minimum.
  int max_step_multiple = 0;
  /// Once a drag's path is done, where the barriers' Hessian touches at most this many free
  /// vertices, the direction is the model's exact Newton step, by the Woodbury identity from A's
  /// factor and the block of A^-1 on those vertices (kept between iterations and solves: one
  /// solve with the factor per vertex new to it, and two per direction), instead of the local
  /// solve and CG below (one solve per CG iteration; on a pose of CGAL's refined_elephant 10 to 14
  /// of them, with 50 to 120 vertices touched). Not during a drag: there the exact directions let
  /// a sliver whose normal turns sideways creep on where CG's stall it and the caller tries
  /// another way at once. 0: never (generation: its repairs touch thousands of vertices).
  int exact_direction_vertices = 0;
  int cg_iterations = 20;      ///< cap on CG iterations per direction (0: the plain A^-1 step)
  double cg_tolerance = 0.1;   ///< relative residual (A^-1 norm) at which CG stops
  /// Before CG, the model is solved exactly on the vertices within this many rings of those the
  /// barriers act on (a small sparse factorisation); -1 skips it.
  int local_rings = 2;
  /// Local systems of at least this many rows (3 per vertex) are factored by CHOLMOD's
  /// supernodal Cholesky, its fill-reducing ordering chosen by CHOLMOD (AMD, or METIS where AMD
  /// fills much), instead of Eigen's simplicial LDLT, whose fill outgrows it on large repairs
  /// (docs/guarded-generation.md "Large repairs"). An indefinite system falls back to the LDLT.
  int supernodal_rows = 150000;
  /// Smaller local systems take the supernodal factor too when the LDLT's analysis predicts at
  /// least this much work (the sum of the factor's squared column counts, >= 0): parts coupled
  /// by contacts across narrow gaps fill far more than a surface's own graph, and rows alone do
  /// not tell (docs/guarded-generation.md "Parts close together").
  double supernodal_flops = 1e9;
  /// The volume barrier's Hessian in the directions: each tet's whole Hessian projected onto its
  /// positive eigenvalues (true) or its Gauss-Newton part (false; VolumeBarrier::add_hessian).
  bool projected_volume_hessian = false;
  /// The contact barrier's Hessian: each pair's projected onto its positive eigenvalues (true) or
  /// its Gauss-Newton part along the distance (false; ContactGuard::add_hessian).
  bool projected_contact_hessian = true;
  /// Tets left out of the volume barrier and bound (empty or one flag per tet): those that
  /// cannot be valid (around unextrudable vertices); they may stay inverted.
  std::vector<char> skip_tets;
  /// Boundary triangles left out of contacts (empty or one flag per row of the boundary), e.g.
  /// around the crossings of a base that intersects itself.
  std::vector<char> excluded_triangles;
  /// Contacts between primitives whose vertices are all fixed count too (their barrier and step
  /// bound). Off where the fixed vertices never move relative to each other (generation's base)
  /// or their motion is the caller's to answer for (a deformation's base frames); on for drags
  /// whose fixed vertices are hard handles moving apart from each other, so that a drag that
  /// would push one handle through another, or fold a shell of handles onto itself, stops at
  /// contact instead.
  bool guard_fixed_pairs = false;
};

struct GuardedSolveOptions {
  int max_iterations = 50;
  double tolerance = 1e-5; ///< stop when the relative decrease of E_guard is below this
  /// The tolerance is relative to the larger of this and the current E_guard (e.g. the whole
  /// shell's energy when only a part of it is solved for; 0: E_guard alone).
  double energy_scale = 0;
  /// Called after every iteration with (iteration, E_guard, seconds since the solve started).
  std::function<void(int, double, double)> progress;
  /// The prescribed motion's length as a fraction of the motion it finishes (in (0, 1]; e.g. a
  /// retried drag's rest of its path). A contact-guarded drag is stalled when its last 20
  /// iterations did less than 1e-3 of that whole motion, so a retry is not held to a finer
  /// pace than the attempt it continues.
  double path_scale = 1;
};

struct GuardedSolveResult {
  int iterations = 0;
  std::vector<double> energy; ///< E_guard: energy[0] at the start, then one per iteration
  bool converged = false;     ///< stopped by the tolerance (not by max_iterations or a stall)
  double seconds = 0;
  /// Fraction of the prescribed motion of the fixed vertices done (1 when none was given or when
  /// it completed; less when the bounds stopped it, e.g. a motion that would pinch the layer).
  double path_done = 1;
  int cg_iterations = 0;       ///< total over all directions
  int backtracks = 0;          ///< total line search halvings
  int clamped_steps = 0;       ///< iterations whose step the tet or contact bound cut below 1
  int held_steps = 0;          ///< of those, taken with the vertices that cut them held (hold_rounds)
  int lengthened_steps = 0;    ///< iterations whose plain step was taken longer (max_step_multiple)
  double final_energy = 0;     ///< E alone (the shell energy, no barriers) at the result
  int active_tets = 0;         ///< tets inside the volume barrier at the result
  double min_relative_volume = 0; ///< smallest det F over the guarded tets at the result
  int active_contacts = 0;     ///< boundary pairs inside the contact barrier at the result
  int supernodal_solves = 0;   ///< local systems factored by CHOLMOD (supernodal_rows and above)
  int reused_orderings = 0;    ///< of those, factored with the ordering found for an earlier one
};

class GuardedSolver {
public:
  /// `rest` over `num_vertices` (2n: base i is i, top i is n + i); `fixed` as in ShellSolver;
  /// `boundary` the layer's boundary surface (shell_boundary(F, n)).
  /// \throws InputError on bad parameters (keep_fraction, volume_weight, contact_distance, CG, holding,
  ///         contact_stiffness), or as the ShellSolver, VolumeBarrier and ContactGuard built here
  ///         (bad ids or sizes, a free part); std::runtime_error when CHOLMOD fails.
  GuardedSolver(const RestTets& rest, int num_vertices, const std::vector<int>& fixed, const ShellBoundary& boundary,
                GuardedSolverParameters parameters);
  /// The same on `arap`, a solver the caller built with hard fixed vertices only (no soft
  /// constraints), shared instead of assembled and factored again: a guarded pose hands its
  /// full level's, whose matrix is the one this solver would build. Its fixed vertices are those
  /// it does not solve for. \throws InputError when `arap` is null, or on bad parameters as above.
  GuardedSolver(std::shared_ptr<const ShellSolver> arap, const ShellBoundary& boundary,
                GuardedSolverParameters parameters);
  ~GuardedSolver();
  GuardedSolver(GuardedSolver&&) noexcept;
  GuardedSolver& operator=(GuardedSolver&&) noexcept;

  /// Minimises E_guard from X (num_vertices x 3, valid: every guarded tet positive, no guarded
  /// boundary pair touching). X is overwritten with the result, which
  /// is valid too. With `fixed_targets` (num_vertices x 3, only rows of fixed vertices read), the
  /// fixed vertices move from their rows in X towards them along straight lines as described
  /// above.
  /// \throws InputError when X or fixed_targets is not num_vertices x 3, options are out of range
  ///         (max_iterations < 0, tolerance < 0) or X is not valid. std::runtime_error if a drag step
  ///         leaves the valid set (a bug: the step bounds forbid it).
  GuardedSolveResult solve(Eigen::MatrixXd& X, const GuardedSolveOptions& options = {},
                           const Eigen::MatrixXd& fixed_targets = {});

  /// Other parameters for the following solves, e.g. weaker barriers after a first solve (as
  /// generation's relaxation rounds do): the ARAP system and the contact primitives are kept, a
  /// fraction of the cost of a new solver on a large shell. skip_tets and excluded_triangles must
  /// be those in effect (set_skipped_tets and set_excluded_triangles change them), and
  /// contact_distance positive exactly when it was at construction.
  /// \throws InputError on bad parameters (as the constructor) or on a change of those three.
  void set_parameters(GuardedSolverParameters parameters);

  /// Other tets left out of the volume barrier and the step bound for the following solves (as
  /// GuardedSolverParameters::skip_tets; e.g. the prisms at the vertices a moving base makes
  /// unextrudable). Every tet guarded from then on must be positive in the states solved from.
  /// \throws InputError when skip has neither 0 nor one flag per tet.
  void set_skipped_tets(std::vector<char> skip);

  /// Other boundary triangles left out of contacts for the following solves (as
  /// GuardedSolverParameters::excluded_triangles; e.g. around the crossings a moving base makes).
  /// `boundary` must be the construction's (not kept: generation's solvers never need it again,
  /// and on millions of faces it is a sizeable copy). The contact guard is built again, its
  /// support caps dropped: cap_contact_support again.
  /// \throws InputError when excluded has neither 0 nor one flag per boundary triangle.
  void set_excluded_triangles(const ShellBoundary& boundary, std::vector<char> excluded);

  /// Keeps every free vertex within `radius` (model units) of its row in `anchor` in the
  /// following solves: a step is also cut where a free vertex would leave that ball, as the tet
  /// and contact bounds cut it. A solver over a part of a larger shell (generation's repair)
  /// leaves out the boundary triangles beyond where its vertices can go; this makes that a bound.
  /// An infinite radius lifts it.
  /// \throws InputError when anchor is not num_vertices x 3 or radius is not positive.
  void confine(const Eigen::MatrixXd& anchor, double radius);

  /// ContactGuard::cap_support on the contact barrier (no-op without contacts): pairs close at X
  /// (a rest state) get a support below that closeness. \throws InputError as cap_support.
  void cap_contact_support(const Eigen::MatrixXd& X, double fraction);

  /// E_guard at X (+infinity when X is not valid for the barriers).
  /// \throws InputError when X is not num_vertices x 3.
  double energy(const Eigen::MatrixXd& X);

  const ShellSolver& shell_solver() const;
  const VolumeBarrier& volume_barrier() const;
  const GuardedSolverParameters& parameters() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell
