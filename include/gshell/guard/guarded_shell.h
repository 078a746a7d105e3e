#pragma once
// Guarded shell generation: the top of a shell optimised towards ideal prisms (the energy of the
// rigid and curvature methods) from a valid start, staying valid (guarded_solver.h). Where the
// target thickness does not fit, the layer thins as little as the barriers need; elsewhere the
// result is close to the unguarded optimum.
#include <gshell/guard/extrusion_directions.h>
#include <gshell/guard/guarded_solver.h>
#include <gshell/guard/valid_start.h>
#include <gshell/shell/smoothed_normals.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <functional>
#include <vector>

namespace gshell {

/// Parameters of the guard, relative to the shell's own scales (see docs/guarded-generation.md).
struct GuardOptions {
  /// Relative tet volume (det F against the ideal prism's tet) below which the volume barrier
  /// pushes back, in (0, 1].
  double j_hat = 0.1;
  /// Weight of the volume barrier (dimensionless; its terms are rest volume times psi(J / j_hat)).
  double volume_weight = 1.0;
  /// Contact barrier support dhat as a fraction of min(eta, mean base edge length) (>= 0; 0 turns
  /// contacts off: only tets are guarded, intersections are not prevented). Generation uses 0.03
  /// (generation_guard_options()).
  double contact_distance = 0.1;
  /// Weight of the contact barrier (dimensionless): the barrier (length^4) is scaled by
  /// contact_weight * A / dhat^3, A the mean base area per vertex, so that at dhat / 2 its push
  /// is about contact_weight * 4 A, comparable with what squashing a prism costs the shell energy.
  double contact_weight = 0.5;
  /// Deformation and pose only (their frame guard): each pair's support is capped at this fraction
  /// of how close its vertices lie to other parts of the boundary in the rest shell
  /// (ContactGuard::cap_support), so that parts of the rest shell closer together than the support
  /// do not push each other apart in every frame (in [0, 1]; 0: the support is the same everywhere).
  double contact_rest_fraction = 0.5;
  /// Each step keeps every tet above this fraction of its volume and every boundary pair above
  /// this fraction of its distance, in (0, 1).
  double keep_fraction = 0.1;
  int cg_iterations = 20;     ///< CG iterations per Newton direction, at most
  double cg_tolerance = 0.1;  ///< relative CG residual
  /// GuardedSolverParameters::hold_rounds (>= 0; generation: 4, in the repair only). A deformation
  /// frame's or pose step's mend holds on its own terms (generation's rounds, steps cut below 0.005)
  /// whatever this is (FrameGuard::mend).
  int hold_rounds = 0;
  /// GuardedSolverParameters::anderson_history (>= 0; deformation and pose: 5, frame_guard_options).
  int anderson_history = 0;
  /// GuardedSolverParameters::max_step_multiple (>= 0; deformation and pose: 64, frame_guard_options).
  int max_step_multiple = 0;
  /// GuardedSolverParameters::exact_direction_vertices (>= 0; deformation and pose: 256,
  /// frame_guard_options).
  int exact_direction_vertices = 0;
  /// GuardedSolverParameters::local_rings: the direction's exact local solve covers the vertices
  /// within this many rings of those the barriers act on (generation: 4, where it reaches the
  /// whole repair region's coupling and the directions are the model's exact Newton steps:
  /// dino 44 -> 30 iterations; -1 skips it).
  int local_rings = 2;
  /// GuardedSolverParameters::supernodal_rows (>= 0).
  int supernodal_rows = 150000;
  /// GuardedSolverParameters::supernodal_flops (>= 0).
  double supernodal_flops = 1e9;
  /// GuardedSolverParameters::projected_volume_hessian (generation: true).
  bool projected_volume_hessian = false;
  /// GuardedSolverParameters::projected_contact_hessian (generation: false).
  bool projected_contact_hessian = true;
  /// The vertex normal is the extrusion direction where it sees every incident face with at least
  /// this cosine margin (extrusion_directions), in [-1, 1].
  double normal_margin = 0.5;
  /// The paper's iterations start from the offset along the vertex normals smoothed over this
  /// fraction of eta (smoothed_vertex_normals; 0: the raw normals, the paper's offset surface;
  /// >= 0). The optimum averages the base's normals over about the thickness, which local/global
  /// iterations spread by about a face per iteration: bunny00 split twice at ratio 0.02, 16 -> 7
  /// iterations to the same energy; on CGAL's coarser models at 0.01-0.05 about as many in total
  /// (-2 %, -9 %, +1 %), ending within 0.3 % of the energy either way (docs/scale.md, "A start
  /// smoothed at the layer's scale"). Not used when the caller gives the first top. Generation: 0.3.
  double start_smoothing = 0;
  double start_thinning = 0.5; ///< ValidStartOptions::thinning
  double start_spread = 0;     ///< ValidStartOptions::spread
  int start_refine = 6;        ///< ValidStartOptions::refine_passes (>= 0)
  double start_backoff = 0.7;  ///< ValidStartOptions::backoff, in (0, 1]
  /// ValidStartOptions::max_rounds (>= 1): a vertex is thinned at most one time fewer; the start
  /// gives up when every vertex of what is left has been, and leaves what it could not mend out
  /// of the guard (then reported, `GuardedShell::start`). 40 reach 2^-39 of eta; only a
  /// degenerate base needs them all.
  int start_max_rounds = 40;
  /// The start pulls an invalid top vertex towards its base vertex along the line joining them
  /// when that line sees every incident face with at least this cosine margin, otherwise along a
  /// path that bends towards the extrusion direction (ValidStartOptions::straight_margin), (0, 1].
  double start_margin = 0.1;
  /// Top vertices of unextrudable vertices are held at this fraction of eta along their best
  /// direction (the prisms around them cannot all be valid; only those are left unguarded).
  double unextrudable_thickness = 0.1;
  /// The guarded solver moves the top vertices the start pulled in and this many rings of
  /// neighbours around them; the rest keeps the paper's result (>= 0).
  int repair_rings = 3;
  /// A connected part of the base whose bounding radius is below eta / small_part_ratio keeps the
  /// valid start's top: it is neither repaired nor lifted (GuardedShell::small_part_vertices).
  /// Prisms many times a part's own size have no valid top near them, and a repair of such a part
  /// has all its boundary pairs in contact range (CGAL's elephant beside a speck of radius 1e-4:
  /// 10-20 s per repair iteration -> the whole generation in 0.4 s). The default is the ratio
  /// generation refuses for a whole mesh (kMaxThicknessRatio), so a single-part mesh is never
  /// held. >= 0; 0: no part is held.
  double small_part_ratio = 10;
  /// Top vertices the start pulled below this fraction of their wanted offset are held where the
  /// start put them (their pairs with the base nearby are too close for the contact step bound to
  /// resolve in floating point), in [0, 1).
  double repair_min_scale = 1e-4;
  /// Where repair_min_scale holds any top, the lifting also runs from the valid start alone, with
  /// no repair before it, and the result with the lower shell energy E is kept. Around tops held
  /// nearly on their base the repair can move the neighbours where they block them: on CGAL's
  /// double-torus-example (tops at 3e-5 of their offset in tight creases) the stretch against
  /// the unguarded result at 0.01 / 0.03 / 0.05 falls 1.040 / 1.164 / 1.140 -> 1.040 / 1.086 /
  /// 1.091 (docs/guarded-generation.md, "Lifting from the start alone"). Generation: true.
  bool try_lift_only = false;
  /// Iterations of the guarded solver at most (-1: the solve's max_iterations, as the paper's,
  /// extended by repair_budget).
  int repair_iterations = -1;
  /// With repair_iterations = -1: the repair may run past the solve's max_iterations while its
  /// iterations times its repaired vertices stay within this (at most 300 iterations; 0: no
  /// extension). Small repairs that stop unconverged at 50 iterations are cheap to finish:
  /// CGAL's mpi_triang (90 vertices, all repaired) converges at about 120, its stretch against
  /// the unguarded result 1.27 -> 1.12 at ratio 0.05, while large ones (camel, cheese, man:
  /// thousands of vertices, still clamped at 50) keep the solve's cap. Generation: 100,000.
  double repair_budget = 0;
  /// Rounds of barrier relaxation after the repair: the repaired region solved again from its
  /// result with barriers weakened once more each round (j_hat / 3, volume and contact weights
  /// / 10, contact support / 2), a round kept only if it lowers the shell energy E (the top's
  /// validity rests on the step bounds, not on the barriers' strength). The default barriers hold
  /// a repaired top further from the limits than it needs: at 0.05 CGAL's mpi_triang's stretch
  /// against the unguarded result drops 1.124 -> 1.098 in one round, femur 1.135 -> 1.118, and a
  /// second round gains at most a third as much (docs/guarded-generation.md). Generation: 1.
  int relax_rounds = 0;
  /// Sweeps of lifting after the repair (and relaxation): top vertices left thinner than 0.9 of
  /// the paper's top are moved, by exactly checked steps that lower the shell energy E, towards
  /// it or along their extrusion direction (docs/guarded-generation.md, "Lifting thin tops").
  /// The repair holds tops the start pulled below repair_min_scale and their neighbours; many
  /// have room once the rest has moved (CGAL's double-torus-example, stretch against the
  /// unguarded result at 0.01 / 0.03 / 0.05: 1.235 / 1.204 / 1.168 -> 1.058 / 1.164 / 1.140).
  /// 0: none. Generation: 4.
  int lift_sweeps = 0;
  /// Deformation frames (those the drag would take more than one sub-step to reach), and pose
  /// steps with hard handles: a frame or step the guard refuses is first mended where it is wrong
  /// (the tops of its violations pulled in as the valid start pulls them, then the guarded solver
  /// over them and this many rings around them, the rest of the solve's result held) and dragged
  /// from the last frame or pose only where that fails (a handle among the tops pulled in, a base
  /// crossing itself). -1: always the drag. Deformation and pose: 10, frame_guard_options; fewer
  /// rings leave the pose further from the drag's minimum (CGAL's homer: energy +0.33 % with 3
  /// rings, +0.02 % with 10; docs/valid-deformation.md, "Mending a refused step" and "Mending a
  /// refused frame").
  int mend_rings = -1;
  /// A mend that ends more than this fraction above the energy of the solve it mends (>= 0) is
  /// not taken as it is: the drag runs too, and the valid state of lower energy is returned. Its
  /// pulled-in tops can settle in another, higher minimum than the drag's (CGAL's dino twisted by
  /// 23 degrees in one frame: +54 % against the drag's +0.25 %), while where validity itself costs
  /// (CGAL's homer bent by 30 degrees: +15 %) both end alike. Deformation and pose: 0.01.
  double mend_max_rise = 0.01;
};

/// \throws InputError naming the parameter unless every field is in range.
void check_guard_options(const GuardOptions& options);

/// The valid start's options as `options` sets them (its start_* fields), with `fallback_length`
/// (model units, > 0) where a top has no length of its own to thin.
ValidStartOptions valid_start_options(const GuardOptions& options, double fallback_length);

/// GuardOptions{} with what generation uses (GenerateOptions::guard): the contact support 0.03 of
/// min(eta, mean edge) instead of 0.1, the projected volume-barrier Hessian, the Gauss-Newton
/// contact Hessian, a 4-ring local solve and a repair budget of 100,000 vertex-iterations
/// (docs/guarded-generation.md, "Repair directions"; deformation frames take the same Hessians and
/// local solve with the contact support 0.1, frame_guard_options() in deform/shell_deformer.h;
/// pose keeps GuardOptions{}). Where the start thins a region, its top lies close to its
/// base over many triangles; a tenth of the edge length puts tens of thousands of pairs inside
/// the barrier on hard models (dino: 27k), each a 12 x 12 Hessian per iteration, and their push
/// holds the top thinner than it needs to be. docs/guarded-generation.md has the measurements.
GuardOptions generation_guard_options();

struct GuardedShell {
  Eigen::MatrixXd top;                 ///< n x 3
  ExtrusionDirections directions;      ///< directions.unextrudable: vertices no direction serves
  /// Rim vertices among those of what the start could not mend whose side walls cut through their
  /// own faces along their direction (rim_vertices_with_blocked_walls): no thickness mends them.
  /// Reported with the unextrudable vertices; ascending.
  std::vector<int> blocked_rim_vertices;
  std::vector<std::pair<int, int>> base_self_intersections; ///< pairs of base faces (the input's)
  /// Per row of shell_boundary(F, n): the triangles the guard cannot keep clean, near the base's
  /// own crossings and around unextrudable vertices (the triangles excluded from contacts and
  /// every triangle sharing a vertex with one). Any two other triangles do not intersect.
  std::vector<char> unprotected_triangles;
  int unprotected_faces = 0;           ///< faces with a triangle in unprotected_triangles
  int repaired_vertices = 0;           ///< top vertices the guarded solver moved
  /// Top vertices of the repair's region held where the start put them (GuardOptions::repair_min_scale).
  int held_vertices = 0;
  /// Base vertices of the parts too small for the thickness (GuardOptions::small_part_ratio),
  /// ascending: their tops are the valid start's.
  std::vector<int> small_part_vertices;
  double small_part_radius = 0; ///< eta / small_part_ratio (model units; 0: no part is held)
  /// The top is the start lifted with no repair before (GuardOptions::try_lift_only): it ended
  /// at the lower energy. repaired_vertices, solve and relax are then those of no repair.
  bool lift_only = false;
  NormalSmoothing smoothing;           ///< of the start's normals (GuardOptions::start_smoothing)
  SolveResult paper;                   ///< the paper's iterations that give the wanted top
  Eigen::MatrixXd paper_top;           ///< that top (n x 3): start.certificate is its certificate
  ValidStart start;                    ///< that top, pulled in where it is not valid
  /// The guarded iterations from the start. Its fields on the result (final_energy, active_tets,
  /// min_relative_volume, active_contacts) describe the returned top, after relaxation if a round
  /// was kept; energy[] and the counters are the repair's own.
  GuardedSolveResult solve;
  /// Nothing to repair, or the repair stopped by its tolerance (not at its cap or a stall).
  bool repair_converged() const { return repaired_vertices == 0 || solve.converged; }
  /// The relaxation rounds after the repair (GuardOptions::relax_rounds).
  struct Relax {
    int iterations = 0;                ///< over all rounds, kept or not
    int kept_rounds = 0;               ///< rounds whose result replaced the one before
    double first_energy = 0;           ///< E at the repair's result, before relaxing
    double seconds = 0;                ///< solve time of all rounds (their factorisations: factor_seconds)
  } relax;
  /// The lifting sweeps after them (GuardOptions::lift_sweeps).
  struct Lift {
    int candidates = 0;                ///< top vertices thinner than 0.9 of the paper's top, movable
    int moves = 0;                     ///< moves kept
    int checks = 0;                    ///< exact checks of moved vertices
    double energy_drop = 0;            ///< E before minus after (>= 0)
    double seconds = 0;
  } lift;
  GuardedSolverParameters parameters;  ///< the absolute parameters used
  double factor_seconds = 0;           ///< matrix assembly + factorisation (both solvers)
  double ideal_seconds = 0;            ///< making the ideal rest tets (when given a function to make them)
  double seconds = 0;                  ///< everything, factor, solve and ideal_seconds included
};

/// The guarded solver's absolute parameters for a shell of thickness eta over base (V, F), from
/// the relative GuardOptions (the same scales as guarded generation: contact distance relative
/// to min(eta, mean edge), contact stiffness to the base area per vertex).
/// \throws InputError as check_guard_options.
GuardedSolverParameters absolute_guard_parameters(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta,
                                                  const GuardOptions& options);

/// The guarded top over base (V, F) towards the rest tets `ideal` (prism_rest_tets of the ideal
/// prisms: normal or curvature), thickness eta (model units): the paper's local/global iterations
/// from an offset surface (the unguarded result), a valid start made from it (valid_start), and
/// the guarded solver from there. `solve` are the paper's iterations' options; its
/// max_iterations, tolerance and progress apply to the guarded solver's too (which combines no
/// iterates: anderson_history is the paper's iterations' only); `linear` chooses how the paper's
/// iterations solve their global steps (the guarded solver, on the region it repairs, always
/// factors). `first_top` (n x 3, optional): the top the paper's iterations start from instead of
/// the (smoothed, GuardOptions::start_smoothing) offset surface (a deformer's solve of a frame:
/// the same minimum, found in fewer iterations).
/// \throws InputError on bad options, thickness eta not positive and finite, `ideal` not 3 tets
///         per face, `first_top` neither empty nor n x 3, or as extrusion_directions (V, F shapes
///         and ids).
GuardedShell guarded_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const RestTets& ideal, double eta,
                           const GuardOptions& options, const SolveOptions& solve,
                           const LinearSolverOptions& linear = {}, const Eigen::MatrixXd& first_top = {});

/// The same with the rest tets made by `make_ideal` where they are needed: for the paper's
/// iterations, and again only if the start thinned a top (the repair, the lifting). In between,
/// through the valid start's certificate, they are not held: at millions of faces the rest tets
/// and the certificate's face data are the two largest allocations, and holding both set the
/// generation's peak memory. `make_ideal` is called once or twice and must give the same tets.
/// \throws as the other overload, and whatever `make_ideal` throws.
GuardedShell guarded_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                           const std::function<RestTets()>& make_ideal, double eta, const GuardOptions& options,
                           const SolveOptions& solve, const LinearSolverOptions& linear = {});

} // namespace gshell
