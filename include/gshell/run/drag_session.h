#pragma once
// An interactive drag of a shell by handles: what `gshell pose --steps`, Python's Poser and the
// browser viewer all drive. It holds the rest shell, the handle groups and the PoseSolver; each
// event moves handles rigidly and solves quickly from a drag-extrapolated start, a rest of the
// mouse runs on to convergence, and the posed shell and the handles can be saved in the formats
// `gshell pose` writes and reads.
//
// Cost model: the solver (rest tets, cluster tree, factorisations) depends only on the handles'
// vertex sets, mode and weight. It is built lazily at the first solve after those change, and
// reused while only targets change. Not thread-safe: one caller at a time.
#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/mesh.h>
#include <gshell/run/pose_run.h>
#include <gshell/run/shell_folder.h>
#include <gshell/shell/shell.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace gshell {

class DragSession {
public:
  /// `rest`: the rest shell (thickness > 0). `surface`: its base's faces and UVs for the saved
  /// folder (default: the rest shell's faces, no UVs). `options`: solver kind and hierarchy, and
  /// the solve limits events use unless told otherwise.
  /// \throws InputError on bad options or a rest shell without faces or thickness.
  explicit DragSession(Shell rest, const PoseOptions& options = {}, TriMesh surface = {});
  ~DragSession();
  /// A moved-from DragSession may only be destroyed or assigned to.
  DragSession(DragSession&&) noexcept;
  DragSession& operator=(DragSession&&) noexcept;

  /// How the saved report names the rest shell and the handle source (e.g. their files).
  void set_names(std::string shell, std::string handles);

  // ---- handles ---------------------------------------------------------------------------
  const HandleSet& handles() const;
  /// Replaces every handle group (vertices, motions, mode, weight); an undo point. The shell
  /// stays where it is; the next solve rebuilds the solver only if the vertex sets, mode or
  /// weight changed.
  /// \throws InputError as check_handles (an empty group, a vertex id outside 0..2n-1, a vertex
  ///         in two groups, a zero rotation axis, non-finite or too large numbers, a soft weight
  ///         outside [kMinSoftWeight, kMaxSoftWeight]).
  void set_handles(HandleSet handles);
  /// Adds a group (its center defaults to its vertices' rest centroid when `center_from_rest`);
  /// returns its index. \throws InputError as set_handles.
  int add_handle(Handle handle, bool center_from_rest = true);
  /// Removes group k. \throws InputError when k is out of range.
  void remove_handle(int k);
  /// Sets group k's vertex set (its center moves to their rest centroid).
  /// \throws InputError when k is out of range, or as set_handles.
  void set_handle_vertices(int k, std::vector<int> vertices);
  /// Sets group k's rigid motion: rotate by `degrees` about `axis` through its center, then
  /// translate. Only the targets change: no rebuild, no undo point.
  /// \throws InputError when k is out of range or a number is not finite / the axis is zero.
  void set_motion(int k, const Eigen::Vector3d& translate, const Eigen::Vector3d& axis = Eigen::Vector3d::UnitZ(),
                  double degrees = 0);

  // ---- solving ---------------------------------------------------------------------------
  /// One event: the handles at `fraction` of their motions, solved from the previous events'
  /// motion continued (PoseSolver::predict_start; along the handles' own motion when only the
  /// fraction changed, else by how far the new targets lie along the last change of targets).
  /// `options` default to the session's (PoseOptions::solve); pass few iterations for a quick
  /// event. Records a step. \throws InputError when the handles leave a part of the shell free.
  PoseStepReport drag(double fraction = 1.0, const std::optional<SolveOptions>& options = std::nullopt);
  /// The cheapest event, for an interactive drag: the handles at `fraction` of their motions,
  /// answered by the hierarchical solver's finest reduced level (HierarchicalSolver::preview,
  /// `iterations` of its iterations) as a change of the state the drag began at (the state of the
  /// last drag() or settle(), its anchor). It costs no full-level work (bunny00: about a tenth
  /// of one full local/global iteration), so it is no minimiser of the full energy: a settle()
  /// afterwards converges it. Not recorded as a step (the report's energy is NaN: not evaluated);
  /// unguarded as a drag() with guard_drag_steps off. For the single-level solver (or guarded
  /// drag steps) it is drag() with `iterations` iterations. \throws InputError as drag().
  PoseStepReport preview(double fraction = 1.0, int iterations = 3);
  /// Runs on from the current state for the same targets (the mouse rests), with the session's
  /// options by default. Records a step. \throws InputError as drag().
  PoseStepReport settle(const std::optional<SolveOptions>& options = std::nullopt);
  /// The same, asking `interrupt` after every iteration (a viewer: "has the next event come?").
  /// When it answers true the solve ends there and nothing is returned or recorded; the shell
  /// keeps the iterate the solver reached if it updates the state in place (the hierarchical
  /// solver does), else its start. Either way the next drag() or settle() goes on from a state
  /// that is no worse than the start. \throws InputError as drag().
  std::optional<PoseStepReport> settle(const std::optional<SolveOptions>& options,
                                       const std::function<bool()>& interrupt);
  /// Builds the solver for the current handle sets now, if they changed since the last build (a
  /// viewer calls it while the user is idle, so the first drag does not pay for it).
  /// \throws InputError as drag().
  void prepare();

  // ---- state -----------------------------------------------------------------------------
  const Shell& rest() const;
  /// The current 2n shell vertices (base rows, then top rows).
  const Eigen::MatrixXd& vertices() const;
  /// The fraction of the last event.
  double fraction() const;
  /// Saves the current state (shell, handles, targets, recorded steps) as an undo point. Handle
  /// edits and reset() make one themselves; a viewer calls it when a drag begins. At most
  /// undo_depth points are kept (the oldest go first); each holds a copy of the 2n vertices.
  void checkpoint();
  /// How many undo points are kept (default kUndoDepth; 0: none). \throws InputError below 0.
  void set_undo_depth(int depth);
  /// Returns to the last undo point; false when there is none.
  bool undo();
  /// The shell back at rest and every handle's motion cleared (groups kept); an undo point.
  void reset();
  static constexpr int kUndoDepth = 32;

  /// Times the solver was built (rest tets, tree, factorisations): tells a cheap event from a rebuild.
  int solver_builds() const;
  /// Levels of the solver built last, the full one included (1 for the single-level solver);
  /// on a small mesh fewer than PoseOptions asks for (HierarchicalSolver). 0 before the first
  /// build (the solver is built lazily, see above).
  int solver_levels() const;
  /// The rest shapes of the shell's prism tets (build_prism_tets order), for per-tet measures.
  const RestTets& rest_tets() const;
  /// The posed shell with its steps since the last reset (from `first_step` on) and its stretch.
  PoseResult result(std::size_t first_step = 0) const;
  /// Steps recorded since the last reset (result()'s full count).
  std::size_t result_step_count() const;
  /// The handles in the handle-file format (docs/handles.md) that `gshell pose --handles` reads:
  /// explicit vertex ids, translate, rotate {axis, degrees, center}.
  nlohmann::ordered_json handles_json() const;
  /// Writes the posed shell folder, as `gshell pose` does (result(first_step) as its report).
  /// \throws InputError on a bad output path (nothing is left behind), as check_pose_output_folder.
  void write(const std::string& dir, std::size_t first_step = 0, const BeforeCommit& before_commit = {}) const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Whether DIR may receive a posed shell: a usable path that is empty, absent or an earlier pose
/// output, and not the folder of the rest shell `shell_dir` (which a pose would replace by itself).
/// \throws InputError naming DIR otherwise.
void check_pose_output_folder(const std::string& dir, const std::string& shell_dir);

} // namespace gshell
