#include <gshell/deform/base_frames.h>

#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/read_mesh.h>

namespace gshell {

std::vector<Eigen::MatrixXd> load_base_frames(const std::vector<std::string>& paths, const Eigen::MatrixXi& F, int n) {
  if (paths.empty()) throw InputError("no base frame given");
  std::vector<Eigen::MatrixXd> frames;
  frames.reserve(paths.size());
  for (const std::string& path : paths) {
    TriMesh mesh = read_mesh(path);
    if (mesh.num_vertices() != n)
      throw InputError(with_file(path, "has " + std::to_string(mesh.num_vertices()) +
                                           " vertices, the shell's base has " + std::to_string(n)));
    if (mesh.F.rows() != F.rows())
      throw InputError(with_file(path, "has " + std::to_string(mesh.F.rows()) + " faces, the shell's base has " +
                                           std::to_string(F.rows())));
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (mesh.F.row(f) != F.row(f))
        throw InputError(with_file(path, "face " + std::to_string(f) + " differs from the shell's base"));
    require_usable_coordinates(mesh.V, path);
    frames.push_back(std::move(mesh.V));
  }
  return frames;
}

} // namespace gshell
