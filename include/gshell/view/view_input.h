#pragma once
// What `gshell view` shows, loaded: one posable shell, or a sequence of shells played as frames.
//
//   a shell folder (generate or pose)         -> one shell, posable
//   a surface file or builtin: spec           -> a shell generated first (the generate job), posable
//   a deform folder (frame_NNNN/ folders)     -> its frames, a sequence
//   several shell folders (e.g. frame folders)-> a sequence, in the order given
//
// Colors: every shell carries the stretch `gshell render` shows for it (the folder's shell.vtu
// `stretch`, or for a generated shell its stretch against the normal prisms), so the viewer and
// the renders agree.
#include <gshell/mesh.h>
#include <gshell/run/generate_run.h>
#include <gshell/shell/shell.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace gshell {

/// A shell thickness for surface inputs when neither thickness nor ratio is given: 2% of the
/// bounding sphere's radius (the README's bowl; a visible layer that poses without collapsing).
constexpr double kViewDefaultThicknessRatio = 0.02;

struct ViewInputOptions {
  /// For a surface input: the generate job's options (its defaults are GenerateOptions{}'s); an
  /// unset thickness becomes the ratio kViewDefaultThicknessRatio.
  GenerateRunOptions generate;
  /// Called after each frame of a sequence is read (frames read, frames in all).
  std::function<void(int, int)> frame_progress;
  /// A sequence whose frames (positions and colors) take more than this many bytes is not held:
  /// only its first frame is read up front, the others when shown (read_view_frame). Holding 80
  /// frames of a 655K-vertex shell would take 3.4 GB and minutes of reading before the page opens.
  std::size_t held_frame_bytes = std::size_t{1} << 30;
};

struct ViewFrame {
  std::string name;             ///< the folder as given / frame_NNNN
  Eigen::MatrixXd X;            ///< 2n x 3 shell vertices (base rows, then top rows); empty if not held
  Eigen::VectorXd face_stretch; ///< per face, as gshell render colors it (m); empty if not held
  /// The eta its thickness colors are measured against: its folder's (several generate outputs
  /// compared side by side differ), or 0 for the input shell's (a frame read from its shell.vtu).
  double thickness = 0;
};

struct ViewInput {
  std::string name;         ///< the input as given (the first one for a list)
  std::string made_by;      ///< report.json `method` or `command` ("rigid", "pose", "deform", ...); may be empty
  Shell shell;              ///< the (first) shell: base, top, faces, thickness eta > 0
  TriMesh surface;          ///< its base's faces and UVs (for a saved pose folder)
  std::vector<ViewFrame> frames; ///< one for a posable shell; 2 or more for a sequence
  /// Whether every frame's X and face_stretch are in memory; else only the first one's are
  /// (ViewInputOptions::held_frame_bytes) and read_view_frame reads the others.
  bool frames_held = true;
  /// When frames are not held: the first frame's prism tets (3m x 4) as its shell.vtu stores them,
  /// against which read_view_frame checks the others. Empty otherwise.
  Eigen::MatrixXi tets;
  /// For a surface input, what `gshell generate` would warn of: the surface's validation
  /// warnings, then the generated shell's (GenerateRun::warnings). For shell folders, that the
  /// first one's report calls its shell invalid (invalid_rest_shell_warning), if it does.
  std::vector<std::string> warnings;

  bool posable() const { return frames.size() == 1; }
};

/// Loads what `gshell view INPUT...` shows (see the table above). A surface is generated with
/// `options.generate` (progress through its solve.progress callback).
/// \throws InputError naming the input when it cannot be read, when frames of a sequence differ in
///         vertex count or faces (frames not held: when shown), or when a thickness is bad, or given
///         for shell folders (which keep their own).
ViewInput load_view_input(const std::vector<std::string>& inputs, const ViewInputOptions& options = {});

/// Frame k of a sequence as shown: input.frames[k] when held, else read from its folder.
/// \throws InputError naming the folder when it can no longer be read or is not a frame of
///         input.shell (checked only now for frames not held), or when k is out of range.
ViewFrame read_view_frame(const ViewInput& input, int k);

} // namespace gshell
