#include <gshell/io/tet_mesh_io.h>

#include "file_bytes.h"
#include "tet_formats.h"

#include <gshell/error.h>
#include <gshell/io/atomic_file.h>


namespace gshell {

namespace {

// Inconsistent arguments are the caller's: InputError, checked before anything is written.
void check_writable(const TetMesh& m) {
  if (m.X.cols() != 3 || (m.T.rows() > 0 && m.T.cols() != 4))
    throw InputError("write_tet_mesh: X must be N x 3 and T K x 4");
  if (m.T.rows() > 0 && (m.T.minCoeff() < 0 || m.T.maxCoeff() >= m.X.rows()))
    throw InputError("write_tet_mesh: tet vertex id out of range");
  auto check = [](const auto& arrays, Eigen::Index rows, const char* kind) {
    for (const auto& [name, data] : arrays) {
      if (name.empty()) throw InputError(std::string("write_tet_mesh: unnamed ") + kind + " array");
      if (data.rows() != rows || (data.cols() != 1 && data.cols() != 3))
        throw InputError(std::string("write_tet_mesh: ") + kind + " array '" + name +
                                    "' must have one row per " + kind + " and 1 or 3 columns");
    }
  };
  check(m.point_data, m.X.rows(), "point");
  check(m.cell_data, m.T.rows(), "cell");
}

std::string format_error(const std::string& path, const std::string& ext) {
  return with_file(path, "unknown tet mesh format '" + (ext.empty() ? std::string("(no extension)") : "." + ext) +
                             "' (supported: .vtu .mesh)");
}

} // namespace

void write_tet_mesh(const std::string& path, const TetMesh& mesh) {
  const std::string ext = io_detail::lower_extension(path);
  if (ext != "vtu" && ext != "mesh") throw InputError(format_error(path, ext));
  check_writable(mesh);
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        if (ext == "vtu") io_detail::write_vtu(out, mesh);
        else io_detail::write_medit(out, mesh);
      },
      true);
}

TetMesh read_tet_mesh(const std::string& path) {
  const std::string ext = io_detail::lower_extension(path);
  if (ext != "vtu" && ext != "mesh") throw InputError(format_error(path, ext));
  const io_detail::FileBytes bytes(path);
  return ext == "vtu" ? io_detail::read_vtu(path, bytes) : io_detail::read_medit(path, bytes);
}

} // namespace gshell
