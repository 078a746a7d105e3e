#include <gshell/deform/base_frames.h>

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>

namespace gshell {

namespace {

// stableNorm, as require_usable_frame's: the squares of a tiny frame's sides underflow.
double diagonal(const Eigen::MatrixXd& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).stableNorm(); }

// require_frame_for_shell, with the rest base's bounding box diagonal given.
void check_frame(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double thickness, double rest_diagonal,
                 const std::string& name) {
  require_usable_frame(V, name);
  const double scale = diagonal(V) / rest_diagonal;
  if (!(scale <= kMaxFrameScale && scale >= 1 / kMaxFrameScale))
    throw InputError(with_file(name, "the frame is " + format_number(scale) +
                                         " times the size of the rest shell's base (other units?): the shell keeps "
                                         "its thickness, so frames must be within " +
                                         format_number(kMaxFrameScale) + " times the rest's size either way"));
  try {
    check_thickness_scale(V, F, thickness);
  } catch (const InputError& e) {
    throw InputError(with_file(name, std::string("the shell's thickness does not fit this frame: ") + e.what()));
  }
}

// One frame file read and checked against the shell's base (n vertices, faces F).
Eigen::MatrixXd read_base_frame(const std::string& path, const Eigen::MatrixXi& F, int n, double thickness,
                                double rest_diagonal) {
  TriMesh mesh = read_mesh_or_builtin(path);
  if (mesh.num_vertices() != n)
    throw InputError(with_file(path, "has " + std::to_string(mesh.num_vertices()) + " vertices, the shell's base has " +
                                         std::to_string(n)));
  if (mesh.F.rows() != F.rows())
    throw InputError(with_file(path, "has " + std::to_string(mesh.F.rows()) + " faces, the shell's base has " +
                                         std::to_string(F.rows())));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (mesh.F.row(f) != F.row(f))
      throw InputError(with_file(path, "face " + std::to_string(f) + " differs from the shell's base"));
  check_frame(mesh.V, F, thickness, rest_diagonal, path);
  return std::move(mesh.V);
}

} // namespace

void require_frame_for_shell(const Eigen::MatrixXd& V, const Shell& rest, const std::string& name) {
  check_frame(V, rest.F, rest.thickness, diagonal(rest.base), name);
}

BaseFrames BaseFrames::load(const std::vector<std::string>& paths, const Shell& rest, std::size_t held_bytes) {
  if (paths.empty()) throw InputError("no base frame given");
  const int n = rest.num_base_vertices();
  const bool hold = static_cast<double>(paths.size()) * n * 3 * sizeof(double) <= static_cast<double>(held_bytes);
  BaseFrames frames;
  frames.rest_diagonal_ = diagonal(rest.base);
  if (hold) frames.held_.reserve(paths.size());
  // Every file is read and checked now, held or not, so that a bad one fails before any work.
  for (const std::string& path : paths) {
    Eigen::MatrixXd V = read_base_frame(path, rest.F, n, rest.thickness, frames.rest_diagonal_);
    if (hold) frames.held_.push_back(std::move(V));
  }
  if (!hold) {
    frames.paths_ = paths;
    frames.F_ = rest.F;
    frames.n_ = n;
    frames.thickness_ = rest.thickness;
  }
  return frames;
}

Eigen::MatrixXd BaseFrames::get(int k) const {
  if (held()) return held_.at(static_cast<std::size_t>(k));
  return read_base_frame(paths_.at(static_cast<std::size_t>(k)), F_, n_, thickness_, rest_diagonal_);
}

} // namespace gshell
