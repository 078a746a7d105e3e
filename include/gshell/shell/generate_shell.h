#pragma once
// Shell generation (docs/design.md "Shell generation", paper §4.1): ideal prisms -> rest tets ->
// local/global solve of the top with the base fixed, started from the offset surface.
#include <gshell/guard/guarded_shell.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/shell_metrics.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/curvature_prisms.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/shell_solver.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <optional>
#include <string>

namespace gshell {

enum class ShellMethod {
  Offset,    ///< the paper's baseline: vertex-normal offset, no optimisation
  Rigid,     ///< optimised towards the normal prisms (the paper's basic method)
  Curvature, ///< optimised towards curvature-sensitive prisms
};

/// "offset", "rigid", "curvature".
std::string to_string(ShellMethod method);
/// Inverse of to_string.
/// \throws InputError "unknown method 'X' (expected rigid, offset or curvature)".
ShellMethod parse_shell_method(const std::string& name);

/// The only source of generation defaults: the CLI's help and Python's keyword defaults read
/// GenerateOptions{}.
struct GenerateOptions {
  ShellMethod method = ShellMethod::Rigid;
  double thickness = 0; ///< eta, model units (> 0)
  /// The paper's local/global iterations, Anderson-accelerated (5 iterates) by default in the
  /// guarded generation: the same minimum in about two thirds of the iterations on fine meshes
  /// (docs/scale.md, "Inexact global steps"); 0 gives the paper's plain iteration. allow_invalid
  /// always runs the plain iteration (anderson_history and linear.cg_relative_tolerance are not
  /// used there).
  SolveOptions solve = {50, 1e-5, {}, 5};
  /// Clamp of the curvature method's in-plane scales (curvature_prisms.h explains the defaults).
  double s_min = kDefaultCurvatureSMin, s_max = kDefaultCurvatureSMax;
  /// Test boundary triangle pairs in the certificate of an unguarded result (offset, or
  /// allow_invalid); off, only its tets are certified (pair counts -1, valid false). A guarded
  /// result is always certified in full: the certificate is the guard's last step.
  bool count_intersections = true;
  /// Rigid and curvature: skip the guard and return the paper's unguarded result (bit for bit
  /// what these methods gave before the guard: plain local/global iterations with exact global
  /// steps), valid or not. Offset is never guarded.
  bool allow_invalid = false;
  GuardOptions guard = generation_guard_options(); ///< parameters of the guarded generation (guarded_shell.h)
  LinearSolverOptions linear; ///< how the global steps are solved (Auto: CG on large meshes)

  /// Throws InputError naming the parameter (thickness, iterations, tolerance, s_min, s_max, the
  /// guard's) when one is out of range.
  void check() const;
};

/// Thicknesses generation accepts, relative to the mesh (check_thickness_scale). A layer of more
/// than kMaxThicknessRatio times the bounding radius is larger than the model many times over:
/// on a closed surface the guard presses its top back nearly onto the base everywhere, and its
/// contact candidates (boxes spanning the whole model) approach every pair of faces (bunny00,
/// rigid: valid in 30 s at ratio 1 and 3, in 212 s at 10, thinned to 1 % of eta; at 1,000 one
/// guarded iteration took 26 s, and the curvature method's prisms turn inside out from about
/// 1e9). Below kMinThicknessScale times the mesh's extent (its radius or its largest coordinate
/// magnitude, whichever is larger) the top differs from the base by fewer than about 5 million
/// units in the last place of the coordinates, and rounding starts to decide the shape (a sphere
/// at ratio 1e-15 came out thinned to 0.6 eta, at 1e-20 with 858 inverted tets).
constexpr double kMaxThicknessRatio = 10;
constexpr double kMinThicknessScale = 1e-9;

/// Thickness for a ratio of the bounding sphere's radius (centre = bounding-box centre, radius =
/// distance to the farthest vertex).
/// \throws InputError unless ratio > 0 and finite, and when V is empty or all one point.
double thickness_from_ratio(const Eigen::MatrixXd& V, double ratio);
/// The same over the vertices the faces F use: a stray vertex far away (left in an exported file)
/// does not change the thickness. Preconditions: face ids in [0, V.rows()).
double thickness_from_ratio(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double ratio);

/// Checks that `thickness` is a layer double precision can build on this mesh: between
/// kMinThicknessScale times its extent and kMaxThicknessRatio times its bounding radius (both over
/// the vertices F uses, as thickness_from_ratio). generate_shell and generate_shell_from_prisms
/// call it for every method, the metrics (CLI and Python) for their normal prisms. Preconditions: face ids in [0, V.rows()), F not empty.
/// \throws InputError naming the thickness, its ratio to the radius and the bound it breaks.
void check_thickness_scale(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double thickness);

struct GenerateTimings {
  double total = 0;  ///< whole generate_shell call, metrics included (seconds)
  double factor = 0; ///< assembling and factoring the system matrix
  double solve = 0;  ///< local/global iterations (guarded: the paper's and the repair's)
  double guard = 0;  ///< guarded generation beyond factor and solve: directions, base
                     ///< self-intersections, valid start (0 when unguarded)
  double metrics = 0; ///< the quality measures (stretch, thickness); the certificate is timed apart
};

/// What the curvature method adds to a generation (paper §4.1 "Curvature Sensitive Method").
struct CurvatureGeneration {
  double s_min = 0, s_max = 0;  ///< clamps used
  CurvaturePrismStats prisms;   ///< prisms that hit the clamps / had their anisotropy limited
  StretchStats own_stretch;     ///< stretch against the curvature prisms it was optimised towards
  double prism_seconds = 0;     ///< curvature + ideal prisms (included in seconds.total)
};

struct GenerateResult {
  Shell shell;
  ShellMethod method = ShellMethod::Rigid;
  /// energy[0] = the start (the offset along normals smoothed over guard.start_smoothing; the
  /// paper's offset when that is 0 or unguarded); for Offset only energy[0] (no iterations). Guarded: the paper's
  /// iterations the guard starts from (its repair iterations are in guard.solve).
  SolveResult solve;
  GenerateTimings seconds;
  /// Stretch against the normal prisms, whatever the method; metrics.certificate is the exact
  /// certificate of the result (a guarded one always tested in full), metrics.certificate.valid()
  /// says whether the layer is an embedding (docs/validity.md). When the guard found nothing to
  /// mend, the certificate is the one its valid start computed of this very top, and its
  /// `seconds` are part of seconds.guard too.
  ShellMetrics metrics;
  std::optional<CurvatureGeneration> curvature; ///< set by the curvature method
  bool guarded = false; ///< made by the guarded generation
  /// Base vertices where no extrusion direction sees every incident face from its positive side
  /// (extrusion_directions), and rim vertices whose side walls cut through their own faces
  /// (GuardedShell::blocked_rim_vertices); only the prisms and walls touching them may stay
  /// invalid. Ascending.
  std::vector<int> unextrudable_vertices;
  /// The guarded generation's own account (start, solver statistics); empty when unguarded.
  GuardedShell guard;
};

/// Rigid-style generation towards the given ideal prisms (6m x 3, ideal_prisms.h layout): rest
/// tets cut from them (prism_rest_tets), base fixed, top started at offset_top and solved.
/// The energy is measured against these prisms; the metrics against the normal prisms.
/// \throws InputError as generate_shell, and when `ideal` is not 6m x 3 or holds a prism turned
///         inside out.
GenerateResult generate_shell_from_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                          const PrismCorners& ideal, const GenerateOptions& options);

/// Generates the shell of (V, F) by options.method (the curvature method fills
/// GenerateResult::curvature).
/// \throws InputError on bad options (GenerateOptions::check), an n x 3 / m x 3 shape mismatch, or
///         a thickness out of scale with the mesh (check_thickness_scale).
GenerateResult generate_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const GenerateOptions& options);

} // namespace gshell
