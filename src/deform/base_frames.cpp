#include <gshell/deform/base_frames.h>

#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>

namespace gshell {

namespace {

// One frame file read and checked against the shell's base.
Eigen::MatrixXd read_base_frame(const std::string& path, const Eigen::MatrixXi& F, int n, double thickness) {
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
  require_frame_for_shell(mesh.V, F, thickness, path);
  return std::move(mesh.V);
}

} // namespace

void require_frame_for_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double thickness,
                             const std::string& name) {
  require_usable_frame(V, name);
  try {
    check_thickness_scale(V, F, thickness);
  } catch (const InputError& e) {
    // The shell keeps its thickness: a frame this far from the rest's size is most likely in other units.
    throw InputError(
        with_file(name, std::string("the shell's thickness does not fit this frame (other units?): ") + e.what()));
  }
}

BaseFrames BaseFrames::load(const std::vector<std::string>& paths, const Eigen::MatrixXi& F, int n, double thickness,
                            std::size_t held_bytes) {
  if (paths.empty()) throw InputError("no base frame given");
  const bool hold = static_cast<double>(paths.size()) * n * 3 * sizeof(double) <= static_cast<double>(held_bytes);
  BaseFrames frames;
  if (hold) frames.held_.reserve(paths.size());
  // Every file is read and checked now, held or not, so that a bad one fails before any work.
  for (const std::string& path : paths) {
    Eigen::MatrixXd V = read_base_frame(path, F, n, thickness);
    if (hold) frames.held_.push_back(std::move(V));
  }
  if (!hold) {
    frames.paths_ = paths;
    frames.F_ = F;
    frames.n_ = n;
    frames.thickness_ = thickness;
  }
  return frames;
}

Eigen::MatrixXd BaseFrames::get(int k) const {
  if (held()) return held_.at(static_cast<std::size_t>(k));
  return read_base_frame(paths_.at(static_cast<std::size_t>(k)), F_, n_, thickness_);
}

} // namespace gshell
