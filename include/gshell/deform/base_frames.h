#pragma once
// The base frames that drive a deformation, read and checked up front.
#include <gshell/shell/shell.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

namespace gshell {

/// Frames may be at most this many times larger or smaller than the rest base (bounding box
/// diagonals). The shell keeps its thickness: a frame in millimetres under a shell built in metres
/// stretched every prism a thousandfold and ran for over a minute (bowl, 4K vertices) to a
/// "valid" frame of stretch 2e6.
constexpr double kMaxFrameScale = 10;

/// What a new pose V of the base of `rest` must meet: require_usable_frame, a size within
/// kMaxFrameScale of the rest base's, and a thickness generation would build on it
/// (check_thickness_scale; e.g. a frame moved 1e12 away, where a double cannot tell the top from
/// the base).
/// \throws InputError "NAME: problem".
void require_frame_for_shell(const Eigen::MatrixXd& V, const Shell& rest, const std::string& name);

/// The base frames of a deformation, in order: held in memory, or, for a sequence too large to
/// hold (a long animation of a sculpt: 1,000 frames of a million vertices are 24 GB), read
/// again from their files one at a time while the deformation runs.
class BaseFrames {
public:
  /// Sequences up to this many bytes of coordinates are held (n x 3 doubles per frame).
  static constexpr std::size_t kHeldBytes = std::size_t{1} << 30;

  BaseFrames() = default;
  /// Frames given in memory (n x 3 each), held.
  explicit BaseFrames(std::vector<Eigen::MatrixXd> frames) : held_(std::move(frames)) {}

  /// Reads every frame file (any mesh format read_mesh knows, or a builtin: spec) and checks each
  /// against the rest shell: same vertex count, identical faces, require_frame_for_shell, all
  /// before returning, so a bad frame fails before any work
  /// is done. Keeps the coordinates when the whole sequence takes at most `held_bytes`, else only
  /// the paths, and get() reads a frame again (and checks it again) when asked for it.
  /// \throws InputError "FRAME: problem" for the first bad frame (unreadable, unknown format,
  ///         other vertex count or faces, beyond the limits), or when `paths` is empty.
  static BaseFrames load(const std::vector<std::string>& paths, const Shell& rest,
                         std::size_t held_bytes = kHeldBytes);

  int size() const { return static_cast<int>(held() ? held_.size() : paths_.size()); }
  /// Whether the coordinates are in memory (else get() reads the files).
  bool held() const { return paths_.empty(); }
  /// Frame k (0-based), n x 3.
  /// \throws InputError when a file read again no longer passes the checks (changed or removed
  ///         since load()).
  Eigen::MatrixXd get(int k) const;

private:
  std::vector<Eigen::MatrixXd> held_;
  std::vector<std::string> paths_; // when not held
  Eigen::MatrixXi F_;              // to check the files read again
  int n_ = 0;
  double thickness_ = 0;
  double rest_diagonal_ = 0; // of the rest base's bounding box
};

} // namespace gshell
