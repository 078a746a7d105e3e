#pragma once
// Base-driven shell deformation (paper §4.2; docs/design.md "Base-driven deformation"): the base
// is moved by someone else, the top follows with the least stretch relative to the rest shell.
#include <gshell/guard/guarded_shell.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gshell {

/// Vertex 1-rings of a triangle mesh, compressed: the neighbours of vertex i (sorted, unique)
/// are ids[start[i] .. start[i+1]).
struct VertexRings {
  std::vector<int> start, ids;
};
VertexRings vertex_rings(const Eigen::MatrixXi& F, int n);

/// How each frame's solve starts. All three keep the new base fixed; they differ in the top.
enum class WarmStart {
  PreviousTop,   ///< the previous frame's top, unchanged
  Translated,    ///< previous top + each base vertex's displacement
  RotatedOffset, ///< new base + previous offset (top - base) rotated by the rotation of the
                 ///< vertex's base 1-ring from the previous to the new frame
  Extrapolated,  ///< RotatedOffset + the previous frame's solver correction (its solution minus
                 ///< its RotatedOffset start), rotated along and scaled by how far the base moves
                 ///< now relative to then (capped at 1; 0 when the base holds still): a
                 ///< constant-velocity guess for smooth motions. The default: fewest iterations (bench/deform.cpp: median 1
                 ///< per frame on the bunny bend, against 2 rotated, 5 translated, 11 previous).
};
const char* warm_start_name(WarmStart w);
/// "previous", "translated", "rotated", "extrapolated". \throws InputError on any other name.
WarmStart parse_warm_start(const std::string& name);

/// The guard options of deformation frames and pose steps (PoseOptions::guard): GuardOptions{}
/// with generation's directions (generation_guard_options: the volume barrier's Hessian projected
/// per tet, the contact barrier's Gauss-Newton Hessian, a 4-ring local solve); the contact
/// support stays 0.1, capped per pair at half of how close the rest shell holds its vertices to
/// other parts of the boundary (contact_rest_fraction); a frame or pose step it refuses is mended
/// in place over 10 rings before any drag (mend_rings). On hard models a dragged frame or pose
/// step meets near-flat tets and wide contacts, as a repair does (docs/valid-deformation.md has
/// the measurements).
GuardOptions frame_guard_options();

/// The only source of the per-frame defaults (the CLI's help and Python's keywords read DeformOptions{}).
struct DeformOptions {
  int max_iterations = 50;
  double tolerance = 1e-4; ///< relative energy change |E_k - E_{k-1}| / E_{k-1} that stops a frame
  WarmStart warm_start = WarmStart::Extrapolated;
  bool measure_stretch = true; ///< fill FrameResult::stretch (one more pass over the tets)
  /// The paper's frames, unguarded: the paper's solve from the warm start, nothing more (frames may
  /// hold inverted tets and intersections). Off (the default): every frame is valid by
  /// construction (docs/valid-deformation.md): the paper's result is taken only when the straight
  /// path from the previous frame to it keeps every tet positive (step bound) and its exact
  /// certificate holds, otherwise the guarded solver drags the shell there from the previous
  /// frame in sub-steps.
  bool allow_invalid = false;
  /// Barrier and step parameters of the guard (relative to the shell's scales, as in generation;
  /// only j_hat, volume_weight, contact_distance, contact_rest_fraction, contact_weight,
  /// keep_fraction, cg_iterations, cg_tolerance, local_rings, mend_rings, mend_max_rise and the two
  /// Hessian choices are read).
  GuardOptions guard = frame_guard_options();
  /// A guarded frame moves its base in sub-steps, each changing no base edge vector by more than
  /// this fraction of the edge's length (about this many radians of turn), in (0, 2].
  double substep_edge_change = 0.1;
  int max_substeps = 64; ///< cap on sub-steps per frame (>= 1)
  /// Every sub-step but the last ends at this relative energy decrease per iteration (or
  /// `tolerance`, when looser); the last is solved to `tolerance`, with the iterations the others
  /// left of their share (sub-steps x max_iterations in all). The sub-steps only keep the drag
  /// near the path of minima, which needs no tight solve (docs/valid-deformation.md, "Sub-steps
  /// solved loosely"). In (0, 1).
  double substep_tolerance = 1e-3;
  /// Fill FrameResult::certificate by the exact certificate (certify_shell, with the base's own
  /// crossings): not counted in FrameResult::seconds.
  bool certify = true;
  /// Called after every iteration of the frame's solves with (iteration, energy, seconds since
  /// that solve began): the paper's solve, then, where the guard works, each guarded sub-step and
  /// a fresh top's generation, each counting from 1 again. It may throw to end the frame (the
  /// exception passes through solve(); reset() the deformer before its next frame).
  std::function<void(int, double, double)> progress;
  /// Called, where set, with the name of each of the frame's solves before its iterations, so
  /// that progress counting from 1 again reads as the next one: "paper" (the paper's solve),
  /// "guard" (unless allow_invalid: the guard built, at the first frame, and the frame tested; no
  /// iterations), then where the guard works "mend" (a refused frame mended in place), "drag K/N"
  /// (the guarded sub-steps; "drag" for one, " (tets only)" once contacts are given up),
  /// "regenerate paper", "regenerate repair", "regenerate relax" (a fresh top over the new base,
  /// generation's stages) and "polish" (the fresh top brought to the frames' minimum).
  std::function<void(const char*)> stage;

  /// \throws InputError naming the parameter (iterations, tolerance, guard options, substeps)
  ///         when it is out of range.
  void check() const;
};

/// A top vertex counts as thinned in a frame when its offset |top_i - base_i| is below
/// kThinnedFraction of its rest offset. \throws InputError unless the four have one shape.
int count_thinned_vertices(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXd& rest_base,
                           const Eigen::MatrixXd& rest_top);

/// How a frame was made.
enum class FrameMethod {
  Unguarded, ///< allow_invalid: the paper's solve only
  Bounded,   ///< the paper's solve, taken: the tet step bound passes on the way and its certificate holds
  Guarded,   ///< the guarded solver from the previous frame (sub-steps), boundary contacts kept apart
  /// The paper's solve (a frame's, or a pose step's), refused, mended where it is wrong
  /// (GuardOptions::mend_rings): its violations' tops pulled in and the guarded solver over them
  /// and a few rings around them, certified.
  Mended,
  TetsOnly,  ///< guarded against inverted tets only: the base forced a contact and no fresh top was clean
  /// The drag stalled (e.g. a sliver base face whose normal swings faster than its top can
  /// follow): the frame's top made afresh over the new base as guarded generation makes one,
  /// towards the same rest shapes, certified, then brought to a minimum of the guarded energy
  /// the dragged frames minimise.
  Regenerated,
  /// Not even that, reported invalid: the paper's solve, or the top made afresh where its exact
  /// certificate finds fewer inverted tets (as many: fewer intersecting pairs).
  Failed,
};
const char* frame_method_name(FrameMethod m);

struct FrameResult {
  Eigen::MatrixXd top;         ///< n x 3 deformed top (top vertex i over base vertex i)
  int iterations = 0;
  /// energy[0] at the warm start, then one per iteration; where the guard replaced the solve's
  /// state (method Guarded or TetsOnly), one more: the returned state's, so back() is always the frame's.
  std::vector<double> energy;
  bool converged = false;      ///< stopped by the tolerance
  StretchStats stretch;        ///< per-tet stretch against the rest shell (incl. inverted tets)
  double seconds = 0;          ///< warm start + solve (excludes the stretch measurement and guard_setup_seconds)
  /// Building the validity guard (FrameGuard), which the first guarded frame does, and a frame
  /// whose DeformOptions::guard differ from the last: setup, as the factorisation is, so kept out
  /// of `seconds` (builtin:sphere:7, 164K base vertices: 1.3 s, against 0.3-0.5 s per frame).
  double guard_setup_seconds = 0;
  double warm_start_seconds = 0; ///< of which the warm start
  double stretch_seconds = 0;  ///< the stretch measurement
  FrameMethod method = FrameMethod::Unguarded;
  int substeps = 0;            ///< sub-steps of a guarded frame (0 when the paper's solve was taken)
  int guarded_iterations = 0;  ///< iterations of the guarded solver over all sub-steps
  int thinned_vertices = 0;    ///< count_thinned_vertices of the frame
  /// certified and not valid: base faces of zero area in the frame (zero_area_faces: a collapsed
  /// edge or collinear corners). Their prisms' tets are flat, so a frame with one is never valid.
  int zero_area_faces = 0;
  /// The exact certificate of the frame (options.certify; counts -1 = not tested otherwise).
  ShellCertificate certificate;
  double certificate_seconds = 0; ///< the certificate beyond what the guard's acceptance computed
  /// The guard certified the frame while accepting it (counted in seconds; certificate filled
  /// but for base_self_intersections).
  bool certified = false;
  /// The certificate holds (options.certify), else the frame's method guarantees it (Bounded,
  /// Guarded).
  bool valid = false;
  /// Base vertices of this frame where no direction sees every incident face from its positive
  /// side (extrusion_directions): some tet of the prisms around each must be inverted, whatever
  /// the top. Found for certified frames that are not valid (empty otherwise), so that a report
  /// can say why; ascending.
  std::vector<int> unextrudable_vertices;
  /// Certified, guarded and not valid, but only where the rest shell is not valid itself
  /// (FrameGuard::only_rest_faults; the frame's base not crossing itself, the frame not Failed):
  /// the faults the guard leaves out.
  bool rest_faults_only = false;
  /// The previous frame was not valid for the guard (TetsOnly or Failed), so the guard started this
  /// one from the last valid frame instead.
  bool resumed = false;
  /// The frame's top is the one made afresh over the new base (method Regenerated, or a Failed
  /// frame where that top had fewer faults than the paper's solve), not a solve from the last frame.
  bool fresh_top = false;
  /// The top made afresh over this frame's base (tried when the drag stalled) could not be made
  /// valid by thinning: parts of the base lie closer to each other than 2^-39 of the layer
  /// (touching, e.g. the ends of a plane bent by exactly 360 degrees), which a frame not valid for
  /// no other reason names as its cause.
  bool base_nearly_touching = false;
};

/// Rest shapes for deforming a shell: its own 3m tets (no cracks). A generated shell may hold a
/// few flat or inverted tets, which cannot be rest shapes (the energy divides by them): those
/// whose volume is below kMinRestVolumeRatio of their normal-prism tet (thickness eta; see
/// docs/design.md "Base-driven deformation") take that ideal tet as their rest shape instead, so deforming pushes them
/// back towards a proper prism rather than preserving the defect. `replaced` (if not null)
/// receives their count. \throws InputError when `shell` fails check_shell (a thickness of 0 is
/// allowed: the mean offset stands in for it).
constexpr double kMinRestVolumeRatio = 1e-3;
RestTets deformation_rest_tets(const Shell& shell, int* replaced = nullptr);

class FrameGuard; // src/deform/frame_guard.h
struct FrameMend;  // src/deform/frame_guard.h

/// Built once per rest shell: rest shapes from deformation_rest_tets, base vertices fixed, system
/// matrix factored once; every frame only back-substitutes.
class ShellDeformer {
public:
  /// \throws InputError "the rest shell: ..." when `rest` fails check_shell (shapes, finite
  ///         coordinates, face ids, a positive thickness); std::runtime_error when CHOLMOD fails
  ///         (out of memory).
  explicit ShellDeformer(const Shell& rest);

  /// Solves the top for a new base (n x 3, the rest base's vertex order), warm-started from the
  /// previous frame (the rest shell before the first frame or after reset()).
  /// \throws InputError on a wrong shape, a non-finite coordinate or bad options (the state is
  ///         left as it was).
  FrameResult solve(const Eigen::MatrixXd& new_base, const DeformOptions& options = {});

  /// The next frame starts from the rest shell again.
  void reset();

  const Shell& rest_shell() const { return rest_; }
  const RestTets& rest_tets() const { return solver_.rest(); }
  double factor_seconds() const { return solver_.factor_seconds(); }
  /// Rest tets that took their ideal shape (see deformation_rest_tets).
  int replaced_rest_tets() const { return replaced_; }
  /// All 2n shell vertices after the last frame (base rows, then top rows).
  const Eigen::MatrixXd& current() const { return current_; }

  /// A moved-from ShellDeformer may only be destroyed or assigned to.
  ShellDeformer(ShellDeformer&&) noexcept;
  ShellDeformer& operator=(ShellDeformer&&) noexcept;
  ~ShellDeformer();

private:
  // Makes X (the paper's solve from the warm start, base rows = the new base) valid from
  // `previous` (the last frame, or resume_ when that frame is not valid): taken if the path to it
  // passes the step bounds, else replaced by the guarded drag.
  void guard_frame(const Eigen::MatrixXd& previous, Eigen::MatrixXd& X, const DeformOptions& options,
                   FrameResult& result);
  // Makes the mend the frame X (FrameMethod::Mended, valid, certified) and carries it forward.
  void take_mended(Eigen::MatrixXd& X, FrameMend& mended, int iterations, FrameResult& result);
  // After a stalled drag: Y = the top over X's base made afresh (guarded_shell towards the
  // solver's rest shapes, its paper iterations started from X's top, the frame's own solve), and
  // its exact certificate. `start_gave_up`: its valid start could not mend everything (parts of the
  // base nearly touching).
  ShellCertificate regenerate(const Eigen::MatrixXd& X, Eigen::MatrixXd& Y, const DeformOptions& options,
                              bool& start_gave_up);

  std::unique_ptr<FrameGuard> guard_; ///< built at the first guarded frame
  bool current_clean_ = true; ///< current_ is valid for the guard (not after TetsOnly or Failed)
  /// When current_ is not clean: the last clean frame (2n x 3), which the next guarded frame starts
  /// from instead. An invalid frame is returned, never carried forward.
  Eigen::MatrixXd resume_;
  Shell rest_;
  int replaced_ = 0;
  ShellSolver solver_;
  Eigen::MatrixXd current_; ///< 2n x 3, the last frame's solution
  VertexRings rings_;                        ///< base 1-rings, for RotatedOffset
  Eigen::MatrixXd last_correction_;          ///< last frame's solution minus its RotatedOffset start
  double last_motion_ = 0;                   ///< ||base change|| of the last frame (Frobenius)
  Eigen::MatrixXd current_normals_;          ///< vertex normals of the last frame's base
};

/// Rotation of each base vertex's neighbourhood from an old to a new base: R_i = the rotation
/// closest to C_i = sum_j (q_j - q_i)(p_j - p_i)^T + (s/2) n_q n_p^T over the 1-ring j of i (p: old
/// base, q: new base, n: unit vertex normals, s = sum_j |p_j - p_i|^2: the normal weighs about
/// as much as each in-plane direction, so flat and boundary rings are determined too). Fitted by
/// Newton steps on the rotation vector from the identity: always a proper rotation, and a few
/// cheap steps for the small frame-to-frame rotations of an animation.
std::vector<Eigen::Matrix3d> ring_rotations(const Eigen::MatrixXd& old_base, const Eigen::MatrixXd& new_base,
                                            const Eigen::MatrixXd& old_normals, const Eigen::MatrixXd& new_normals,
                                            const VertexRings& rings);

/// The RotatedOffset warm start on its own: top_i = q_i + R_i (top_old_i - p_i) with the
/// ring_rotations R_i (returned in `rotations` when it is not null).
Eigen::MatrixXd rotated_offset_top(const Eigen::MatrixXd& old_base, const Eigen::MatrixXd& old_top,
                                   const Eigen::MatrixXd& new_base, const Eigen::MatrixXi& F,
                                   const VertexRings& rings,
                                   std::vector<Eigen::Matrix3d>* rotations = nullptr);


} // namespace gshell
