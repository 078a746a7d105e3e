#pragma once
// Handles for direct shell deformation (paper §4.2, second type): sets of shell vertices moved
// rigidly to target positions. The file format is documented in docs/handles.md.
#include <gshell/shell/shell.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace gshell {

/// One handle: its vertices follow "rotate about `center`, then translate" at full motion; a
/// fraction t in [0,1] of the motion rotates by t*degrees and translates by t*translate.
/// No translate and no rotate = the vertices are held at their rest positions.
struct Handle {
  std::string name;                                         ///< a label (handle files: "name")
  std::vector<int> vertices;                                ///< shell vertex ids (base 0..n-1, top n..2n-1), sorted
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();      ///< model units
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();          ///< rotation axis: any length but zero, only its direction counts
  double degrees = 0;                                       ///< right-handed about `axis`
  Eigen::Vector3d center = Eigen::Vector3d::Zero();         ///< default: centroid of the handle's rest vertices

  friend bool operator==(const Handle&, const Handle&) = default;
};

enum class ConstraintMode {
  Hard, ///< handle vertices are eliminated: they sit exactly on their targets
  Soft, ///< handle vertices are pulled by springs: weight * k * ||x - p||^2 (k below)
};

/// The stiffest soft handles (HandleSet::weight): a handle then sits on its target to about 1e-12
/// of the shell's size, and stiffer springs make the reduced levels' matrices indefinite to rounding.
constexpr double kMaxSoftWeight = 1e12;
/// The weakest: springs that hold the shell in place at all. Below about 1e-16 a spring is lost
/// to rounding next to the shell's stiffness and the system is singular (the bowl pull: solved at
/// 1e-15, "singular" at 1e-18), a message that named the handles' parts, not the weight.
constexpr double kMinSoftWeight = 1e-12;

struct HandleSet {
  std::vector<Handle> handles;         ///< disjoint vertex sets
  ConstraintMode mode = ConstraintMode::Hard;
  /// Soft mode only. Dimensionless: the spring constant is weight times the mean diagonal entry
  /// of the shell's stiffness matrix (sum_t vol_t G_t^T G_t), so the same weight behaves the same
  /// at any model scale. 1 = as stiff as a typical vertex's tie to its neighbours. At most
  /// kMaxSoftWeight, at least kMinSoftWeight.
  double weight = 1000;

  /// Vertices of all handles, handle after handle (the row order of `targets`).
  std::vector<int> constrained_vertices() const;
  /// Target positions (|constrained_vertices()| x 3) for the fraction t of the motion, from the
  /// rest positions of all 2n shell vertices.
  /// \throws InputError when rest_vertices has no row of 3 coordinates for a handle vertex.
  Eigen::MatrixXd targets(const Eigen::MatrixXd& rest_vertices, double fraction) const;

  friend bool operator==(const HandleSet&, const HandleSet&) = default;
};

/// Checks a handle set built in code for a shell of `shell_vertices` (2n) vertices, as
/// parse_handles checks a file's handles. \throws InputError on an empty handle, a vertex id out
/// of range or in two handles, a zero rotation axis, non-finite numbers, a translation or centre
/// coordinate of magnitude max_coordinate_magnitude (1e50) or more, or, in soft mode, a weight
/// outside [kMinSoftWeight, kMaxSoftWeight] (hard mode ignores the weight). Not checked here
/// (parse_handles checks it for a file): targets so far out that the shell's thickness is below
/// kMinThicknessScale of their coordinates.
void check_handles(const HandleSet& handles, int shell_vertices);

/// Every connected part of a shell (base faces F over n base vertices; a part's top goes with it)
/// needs a handle vertex, or the energy does not pin that part in space and no pose is defined.
/// \throws InputError naming the lowest base vertex of the first part without one.
void check_handles_hold_every_part(const HandleSet& handles, const Eigen::MatrixXi& F, int n);

/// The handle file (docs/handles.md) of a handle set: mode, weight (soft mode), and per handle
/// name (if any), explicit vertex ids, translate and rotate {axis, degrees, center}. parse_handles
/// reads it back to the same set.
nlohmann::ordered_json handles_to_json(const HandleSet& handles);

/// Parses a handle file (JSON) against the rest shell: `select` boxes are resolved into vertex ids
/// here. \throws InputError "PATH: problem" on unreadable or malformed files, unknown keys, wrong
/// types, non-finite numbers, ids outside 0..2n-1, empty selections, a zero rotation axis,
/// a vertex in two handles, or no handle at all.
HandleSet read_handles(const std::string& path, const Shell& rest);

/// Same, from the JSON text; `name` is used in error messages. \throws InputError as read_handles.
HandleSet parse_handles(const std::string& json_text, const std::string& name, const Shell& rest);

/// The text of the handle file at `path`. \throws InputError "PATH: ..." when it is a directory
/// or cannot be opened.
std::string read_handle_file(const std::string& path);

/// The checks of parse_handles that need no shell (the JSON itself: syntax, nesting, a key given
/// twice), for a caller that has a long setup to do before the shell exists (`gshell view` on a
/// surface generates it first). \throws InputError as parse_handles.
void check_handle_file_syntax(const std::string& json_text, const std::string& name);

} // namespace gshell
