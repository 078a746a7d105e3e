#pragma once
// Hierarchical dimension-reduction solver for direct shell deformation (paper §5, docs/design.md
// "Hierarchical dimension reduction"). Minimises the same energy as ShellSolver,
// E(x) = sum_t vol_t ||F_t(x) - R_t||_F^2 (+ soft constraint springs), over all 2n shell vertices.
//
// Levels 0..L-2 are reduced: every cluster j of the cluster tree carries an affine map, its
// vertices sit at x_i = M_j (u_i - c_j) + t_j (u = rest positions, c_j = rest centroid), so
// x = B_l z_l with 12 unknowns per cluster, and the reduced matrix A_l = B_l^T L B_l (+ springs)
// is assembled and factored once. Tets inside one cluster have F_t = M_j: one polar decomposition
// serves all of them. By default (cluster_rotations) the tets across cluster borders take the
// rotation of the cluster that owns them as well, so a reduced iteration costs O(cluster pairs),
// independent of the tet count; otherwise each border tet gets its own rotation. The coarsest
// reduced level has about 8 clusters, each finer one 4x as many (down to 8 base vertices per
// cluster on small meshes): 8, 32, 128 and 512 clusters on the bowl and on bunny00 alike.
// Level L-1 is the full problem: a ShellSolver over all 2n vertices (hard handles eliminated),
// driven step by step.
//
// One outer iteration is full_iterations local/global iterations of the full state, preceded on
// every coarse_period-th outer iteration by a coarse-to-fine pass: each reduced level first
// receives its parent's change since the start of the pass, runs a few (Anderson-accelerated)
// local/global iterations with its prefactored matrix, and the finest reduced level's change goes
// into the full state. Anderson acceleration combines the images of whole outer iterations (pass
// and full iterations; anderson_over_passes). (Defaults measured with bench_pose on the bowl,
// bunny00 and four of CGAL's meshes: a pass every iteration with 10 iterations per level.) Two
// couplings of the levels are available:
//  - residual (default): each level starts from the affine fit of the current full state and
//    minimises its energy minus 2 <tau, z>, tau chosen so that its gradient there equals the
//    full gradient seen through its subspace (full approximation scheme; our reading of the
//    paper's "correct z_l and b_l"). Changes are passed on as affine maps (exact embedding).
//  - paper: each level keeps its own parameters between outer iterations and solves (never
//    overwritten by its parent's); the parent's rotation change about its centroid and centroid
//    translation are applied to its children and, at the end, to the full state's vertices.
// Every coarse_period-th outer iteration ends with a line search along the path of the iterates
// (path_extrapolation). Every change handed down is kept only if it does not raise that level's
// objective, and the full state's only if it lowers the full energy (the one acceptance test),
// so the energy never increases across outer iterations. After a rejected pass the reduced levels
// pause for 1, 2, 4, ... outer iterations. The clusters' maps meet piecewise (the paper's subspace).
#include <gshell/solver/cluster_tree.h>
#include <gshell/solver/cluster_weights.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <memory>
#include <vector>

namespace gshell {

/// Positional constraints on shell vertices. Hard ones are eliminated on the full level (the
/// rows of X hold the targets); soft ones add weight * sum_c ||x_c - p_c||^2.
struct PositionConstraints {
  std::vector<int> vertices; ///< distinct shell vertex ids
  bool hard = true;
  double weight = 0;         ///< soft only; absolute (energy per squared model unit)
};

struct HierarchyOptions {
  /// Levels including the full one; 1 = the plain single-level solver. At most: on a mesh too
  /// small for them, reduced levels that would have no more clusters than the one above are not
  /// built (num_levels() tells; 162 base vertices hold 3 reduced levels).
  int levels = 5;
  int splits_per_level = 2;   ///< bisection rounds between successive levels (up to 4x clusters)
  /// Clusters of the coarsest reduced level (its tree depth is log2 of this, rounded); the finer
  /// levels lie splits_per_level bisection rounds apart below it. Fixed, not growing with the
  /// mesh: the slow modes the reduced levels are for (bending and twisting the whole shell between
  /// the handles) need only a few clusters whatever the resolution, and the finer the reduced
  /// levels, the more a coarse pass costs (bunny00 with the finest level at 8 vertices per
  /// cluster: 64 clusters at the top, a pass ~4 full iterations; docs/design.md).
  int coarsest_clusters = 8;
  /// At least this many base vertices per cluster at the finest reduced level (its tree depth is
  /// at most log2(n / this), rounded): on small meshes the levels move up the tree.
  int finest_cluster_size = 8;
  int min_cluster_size = 8;   ///< base vertices; clusters are not split below this
  int level_iterations = 10;  ///< local/global iterations per reduced level and coarse pass (at most)
  /// A reduced level stops its iterations early once its objective falls by less than this
  /// fraction of its value in one iteration (0: always run level_iterations).
  double level_tolerance = 0;
  int full_iterations = 1;    ///< local/global iterations of the full level per outer iteration
  /// The coarse-to-fine pass over the reduced levels runs on outer iterations coarse_period,
  /// 2 coarse_period, ... (1: every outer iteration). With a period > 1 an outer iteration that
  /// already suffices (a drag step from a good start) costs only its full iterations, but
  /// anderson_over_passes needs the same map every iteration (period 1).
  int coarse_period = 1;
  /// Reduced levels cannot hold hard constraints exactly (a few affine maps cannot reach arbitrary
  /// targets), so there they become springs of this weight times the mean diagonal of the
  /// stiffness matrix.
  double reduced_hard_weight = 100;
  /// Couple the levels through the fine residual: each reduced level minimises its energy minus
  /// 2 <tau, z>, with tau chosen so that its gradient at its current state is the full
  /// gradient restricted to its subspace (the paper's correction of b_l; full approximation
  /// scheme). Without it the reduced levels only see the handles, not the full state.
  bool residual_correction = true;
  /// One rotation per cluster for all the tets it owns (those whose corner 0 it holds), border
  /// tets included: a reduced iteration then costs O(cluster pairs) instead of O(tets), at the
  /// price of an approximate reduced energy (the residual coupling still makes the fixed points
  /// agree). Off: tets across cluster borders get their own rotation (the exact subspace energy).
  bool cluster_rotations = true;
  /// Anderson acceleration of every reduced level's iterations within one coarse pass (history
  /// length; 0 = off). Not safeguarded per iteration: the full level keeps a pass's result only
  /// if it lowers the full energy.
  int level_anderson_history = 5;
  /// Every coarse_period outer iterations, after the full iterations, search along the path the
  /// iterates follow: the displacement since the previous such point is added again at 1, 2, 4,
  /// ... times its length, each step kept only while it lowers the energy. Iterations that creep
  /// along a soft mode (a thin shell buckling or snapping through) then cover the way in far fewer
  /// steps (bench_pose bowl, big move: 35 -> 19 outer iterations; the slowest drag step, where
  /// the bowl snaps through: 320 -> 138).
  bool path_extrapolation = true;
  /// Anderson acceleration of the full level's local/global iterations (history length; 0 = off).
  /// An extrapolated iterate is kept only if it lowers the energy.
  int anderson_history = 5;
  /// No coarse pass before this outer iteration of a solve. 2 (default): the first outer
  /// iteration of every solve runs without one, so a drag step from a good start, which often
  /// needs one iteration only, costs one full iteration (bench_pose bowl drag: 2.1-2.5 ms per
  /// step against 11 ms with a pass at iteration 1; bunny00 30-38 ms against 65 ms). Later
  /// starts trade one pull for another: a coarse pass right after the handles moved (the rest of
  /// the shell still at rest) minimises the reduced levels' stiffer energy from a badly distorted
  /// state and can pick another buckling pattern than the full level would. bench_pose --table,
  /// CPU s to 1.001 E*, passes from iteration 1 -> 2: thick half pull another minimum (0.5 %
  /// above) -> 0.41 s, thin twist 1.8 -> 6.8 s, the rest within 10 %; before
  /// anderson_over_passes, 10 took the thick twist into the minimum the single-level solvers
  /// find, at a cost on six other pulls (docs/design.md).
  int first_coarse_iteration = 2;
  /// With reduced levels, a coarse pass every outer iteration (coarse_period 1) and at least one
  /// full iteration: Anderson combines the images of whole outer iterations, G(x) = the full
  /// level's plain local/global steps after the coarse pass from x, instead of the full level's
  /// iterations alone (whose history every kept pass interrupts, so that inside the hierarchy
  /// they ran almost unaccelerated). A combination is kept only if it lowers the energy; one that
  /// does not is dropped, the history kept. bench_pose --table, CPU s to 1.001 E* against a pass
  /// every 2nd iteration without it: thin squeeze 3.0 -> 1.6-1.8, thick pull 3.9-5.1 -> 3.0-3.3,
  /// thin half pull 1.3-1.6 -> 1.0-1.1, and the thin twist reaches a minimum 0.2-0.3 % below the
  /// one every other solver settles in (docs/design.md). Off: the full level's Anderson as before.
  bool anderson_over_passes = true;

  /// \throws InputError naming the first field out of range: levels, splits_per_level,
  /// coarsest_clusters, finest_cluster_size, min_cluster_size and coarse_period below 1; an
  /// iteration count or first_coarse_iteration below 0; level_tolerance outside [0, 1];
  /// reduced_hard_weight not positive and finite; an Anderson history outside
  /// [0, kMaxAndersonHistory]. HierarchicalSolver's constructor calls it.
  void check() const;
};

/// What the solver's parts did (counted per solve, and in all since construction).
struct HierarchyCounters {
  int outer_iterations = 0;
  int full_iterations = 0;       ///< local/global iterations done on the full level
  int coarse_passes = 0;         ///< coarse-to-fine passes run
  int coarse_accepted = 0;       ///< of which the full state kept the result (the rest were rejected)
  /// Parent-to-child handovers within passes not kept because they would have raised the child's objective.
  int rejected_propagations = 0;
  /// Where the energy went down: accepted coarse corrections, full-level iterations, path search
  /// (together energy.front() - energy.back() of a solve).
  double coarse_decrease = 0, full_decrease = 0, path_decrease = 0;
  /// Wall time of the same three parts, seconds.
  double coarse_seconds = 0, full_seconds = 0, path_seconds = 0;
  /// The counts since `earlier` (a copy taken before).
  HierarchyCounters since(const HierarchyCounters& earlier) const;
};

struct HierarchicalSolveResult : SolveResult {
  HierarchyCounters counters;
};

class HierarchicalSolver {
public:
  /// `rest_vertices` are the 2n rest shell vertices the tets' rest shapes come from (base rows
  /// 0..n-1, top n..2n-1), `F` the base faces. Builds the tree, assembles and factors every level.
  /// \throws InputError when options fail HierarchyOptions::check, rest_vertices is not 2n x 3, a tet or face id is
  ///         out of range, the rest shapes are not the tets of rest_vertices (tets listed in
  ///         rest.override_tets may have shapes of their own), soft constraints have
  ///         a weight <= 0, or as ShellSolver's constructor (bad constraint ids, a free part).
  ///         std::runtime_error when CHOLMOD fails otherwise (out of memory).
  HierarchicalSolver(const RestTets& rest, const Eigen::MatrixXd& rest_vertices, const Eigen::MatrixXi& F,
                     const PositionConstraints& constraints, const HierarchyOptions& options = {});
  /// The same, sharing `rest` (the full level and the reduced levels read it in place) instead of
  /// holding a copy: at a million tets a copy is about 100 MB. \throws InputError also when `rest` is null.
  HierarchicalSolver(std::shared_ptr<const RestTets> rest, const Eigen::MatrixXd& rest_vertices, const Eigen::MatrixXi& F,
                     const PositionConstraints& constraints, const HierarchyOptions& options = {});
  ~HierarchicalSolver();
  /// A moved-from HierarchicalSolver may only be destroyed or assigned to.
  HierarchicalSolver(HierarchicalSolver&&) noexcept;
  HierarchicalSolver& operator=(HierarchicalSolver&&) noexcept;

  /// Outer iterations from X (2n x 3), which is overwritten with the result; `targets`
  /// (|constraints.vertices| x 3) are the constraint positions (hard rows of X are set to them).
  /// With the paper coupling the reduced levels continue from the state the previous solve left
  /// (with the residual coupling they restart from X every outer iteration). `options.max_iterations`
  /// and `tolerance` apply to outer iterations; energy[k] is the full energy after outer iteration k.
  /// \throws InputError when X is not 2n x 3 or targets is not |constraints.vertices| x 3.
  HierarchicalSolveResult solve(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, const SolveOptions& options = {});

  /// Full energy of X (with the soft term for soft constraints; hard rows are taken as they are).
  /// \throws InputError as ShellSolver::energy (X not 2n x 3; soft targets of the wrong shape).
  double energy(const Eigen::MatrixXd& X, const Eigen::MatrixXd& targets) const;

  /// Reduced levels back to the rest shape (identity maps).
  void reset();

  /// Interactive previews (a drag event answered in a few milliseconds, docs/viewer.md): the
  /// change reduced level `level` (-1: the finest) finds for new targets, carried onto the full
  /// state. anchor_preview() takes the state X the previews move from (e.g. the settled shell
  /// when a drag begins): the level is fitted to X and its residual coupling to the full level is
  /// frozen there (one full local step), so that for the targets of X the level is at rest and a
  /// drag moves the shell from X smoothly. preview() starts the level where the last preview
  /// left it, moved on by `extrapolate` times the last preview's change of the level when that is
  /// in (0, 2] (a drag-extrapolated start), runs `iterations` (Anderson-accelerated) local/global
  /// iterations of the level for `targets`, and sets X = X_anchor + B (z - z_anchor) with hard
  /// rows at the targets. No full-level work; the energy is not evaluated (a solve() afterwards
  /// converges the full problem). solve() and reset() use the same levels: anchor again after them.
  /// \throws InputError when X or targets have the wrong shape, the solver has no reduced level,
  ///         `level` is out of range or `iterations` < 1; std::logic_error before anchor_preview.
  void anchor_preview(const Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, int level = -1);
  void preview(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, int iterations, double extrapolate = 0);

  int num_levels() const;                ///< including the full level
  const ClusterTree& tree() const;
  /// The level accessors below: \throws std::out_of_range unless 0 <= level < num_levels()-1.
  int tree_depth(int level) const;       ///< cluster tree depth of reduced level `level`
  int num_clusters(int level) const;     ///< clusters of a reduced level
  /// Positions B_l z_l of reduced level l (0 <= l < num_levels()-1), 2n x 3.
  Eigen::MatrixXd level_positions(int level) const;
  /// How the affine maps of reduced level l act on the base vertices (piecewise: its own cluster).
  const ClusterWeights& level_weights(int level) const;
  /// Affine maps of reduced level l: 4 rows per cluster, [M_j^T; t_j^T] (x^T = [(u-c_j)^T 1] Z_j).
  const Eigen::MatrixXd& level_parameters(int level) const;
  /// Energy of reduced level l at its current parameters (springs included).
  double level_energy(int level, const Eigen::MatrixXd& targets) const;
  double factor_seconds() const;        ///< tree + assembly + factorisations in the constructor
  /// Counters summed over every solve since construction, including solves that a progress
  /// callback ended by throwing.
  const HierarchyCounters& counters() const;
  /// The full level's solver (the single-level solver of these constraints), for a caller that
  /// needs the same system: a guarded pose's guard shares it instead of factoring it again.
  std::shared_ptr<const ShellSolver> full_level() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The single-level solver for these constraints: hard ones eliminated, soft ones as springs.
/// \throws InputError as ShellSolver's constructor.
std::unique_ptr<ShellSolver> make_shell_solver(const RestTets& rest, int num_vertices,
                                               const PositionConstraints& constraints);
/// The same, the solver sharing `rest`.
std::unique_ptr<ShellSolver> make_shell_solver(std::shared_ptr<const RestTets> rest, int num_vertices,
                                               const PositionConstraints& constraints);

/// Mean diagonal entry of the stiffness matrix sum_t vol_t G_t^T G_t (the scale of soft weights).
double mean_stiffness(const RestTets& rest, int num_vertices);

} // namespace gshell
