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

/// How each frame's solve starts. All three keep the new base fixed; they differ in the top.
enum class WarmStart {
  PreviousTop,   ///< the previous frame's top, unchanged
  Translated,    ///< previous top + each base vertex's displacement
  RotatedOffset, ///< new base + previous offset (top - base) rotated by the rotation of the
                 ///< vertex's base 1-ring from the previous to the new frame (the default: it
                 ///< needs the fewest iterations, see bench/deform.cpp)
};
const char* warm_start_name(WarmStart w);
/// "previous", "translated", "rotated"; throws InputError otherwise.
WarmStart parse_warm_start(const std::string& name);

struct DeformOptions {
  int max_iterations = 50;
  double tolerance = 1e-4; ///< relative energy change |E_k - E_{k-1}| / E_{k-1} that stops a frame
  WarmStart warm_start = WarmStart::RotatedOffset;
  bool measure_stretch = true; ///< fill FrameResult::stretch (one more pass over the tets)
};

struct FrameResult {
  Eigen::MatrixXd top;         ///< n x 3 deformed top (top vertex i over base vertex i)
  int iterations = 0;
  std::vector<double> energy;  ///< energy[0] at the warm start, then one per iteration
  bool converged = false;      ///< stopped by the tolerance
  StretchStats stretch;        ///< per-tet stretch against the rest shell (incl. inverted tets)
  double seconds = 0;          ///< warm start + solve (excludes the stretch measurement)
  double stretch_seconds = 0;  ///< the stretch measurement
};

/// Built once per rest shell: rest shapes = the shell's own 3m tets (no cracks), base vertices
/// fixed, system matrix factored once; every frame only back-substitutes.
class ShellDeformer {
public:
  /// Throws InputError when the shell has a tet of non-positive volume.
  explicit ShellDeformer(const Shell& rest);

  /// Solves the top for a new base (n x 3, the rest base's vertex order), warm-started from the
  /// previous frame (the rest shell before the first frame or after reset()). Throws InputError
  /// on a wrong row count or a non-finite coordinate.
  FrameResult solve(const Eigen::MatrixXd& new_base, const DeformOptions& options = {});

  /// The next frame starts from the rest shell again.
  void reset();

  const Shell& rest_shell() const { return rest_; }
  const RestTets& rest_tets() const { return solver_.rest(); }
  double factor_seconds() const { return solver_.factor_seconds(); }
  /// All 2n shell vertices after the last frame (base rows, then top rows).
  const Eigen::MatrixXd& current() const { return current_; }

private:
  Shell rest_;
  ShellSolver solver_;
  Eigen::MatrixXd current_; ///< 2n x 3, the last frame's solution
  std::vector<std::vector<int>> neighbours_; ///< base 1-rings, for RotatedOffset
};

/// The RotatedOffset warm start on its own: for each vertex i, R_i = rotation closest to
/// sum_j (q_j - q_i)(p_j - p_i)^T + s^2 n_q n_p^T over the 1-ring j of i (p: old base, q: new
/// base, n: area-weighted vertex normals, s: mean 1-ring edge length, so flat rings are still
/// determined), and top_i = q_i + R_i (top_old_i - p_i).
Eigen::MatrixXd rotated_offset_top(const Eigen::MatrixXd& old_base, const Eigen::MatrixXd& old_top,
                                   const Eigen::MatrixXd& new_base, const Eigen::MatrixXi& F,
                                   const std::vector<std::vector<int>>& neighbours);

/// Vertex 1-rings (sorted, unique) of a triangle mesh with n vertices.
std::vector<std::vector<int>> vertex_neighbours(const Eigen::MatrixXi& F, int n);

} // namespace gshell
