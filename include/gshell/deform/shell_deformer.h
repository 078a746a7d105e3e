#pragma once
// Base-driven shell deformation (paper §4.2, first type; DESIGN.md "Shell deformation"): the base
// is moved by someone else, the top follows with the least stretch relative to the rest shell.
#include <gshell/quality/stretch.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <Eigen/Core>
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
/// "previous", "translated", "rotated", "extrapolated"; throws InputError otherwise.
WarmStart parse_warm_start(const std::string& name);

/// The only source of the per-frame defaults (the CLI's help and Python's keywords read DeformOptions{}).
struct DeformOptions {
  int max_iterations = 50;
  double tolerance = 1e-4; ///< relative energy change |E_k - E_{k-1}| / E_{k-1} that stops a frame
  WarmStart warm_start = WarmStart::Extrapolated;
  bool measure_stretch = true; ///< fill FrameResult::stretch (one more pass over the tets)

  /// \throws InputError naming the parameter (iterations, tolerance) when it is out of range.
  void check() const;
};

struct FrameResult {
  Eigen::MatrixXd top;         ///< n x 3 deformed top (top vertex i over base vertex i)
  int iterations = 0;
  std::vector<double> energy;  ///< energy[0] at the warm start, then one per iteration
  bool converged = false;      ///< stopped by the tolerance
  StretchStats stretch;        ///< per-tet stretch against the rest shell (incl. inverted tets)
  double seconds = 0;          ///< warm start + solve (excludes the stretch measurement)
  double warm_start_seconds = 0; ///< of which the warm start
  double stretch_seconds = 0;  ///< the stretch measurement
};

/// Rest shapes for deforming a shell: its own 3m tets (no cracks). A generated shell may hold a
/// few flat or inverted tets, which cannot be rest shapes (the energy divides by them): those
/// whose volume is below kMinRestVolumeRatio of their normal-prism tet (thickness eta, DESIGN.md
/// "Shell generation") take that ideal tet as their rest shape instead, so deforming pushes them
/// back towards a proper prism rather than preserving the defect. `replaced` (if not null)
/// receives their count.
constexpr double kMinRestVolumeRatio = 1e-3;
RestTets deformation_rest_tets(const Shell& shell, int* replaced = nullptr);

/// Built once per rest shell: rest shapes from deformation_rest_tets, base vertices fixed, system
/// matrix factored once; every frame only back-substitutes.
class ShellDeformer {
public:
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

private:
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
