// Surface writers: OBJ and OFF here, PLY in write_ply.cpp. STL is not written: it stores corner
// points, not vertices, so it cannot keep the vertex order later stages rely on.
#include <gshell/io/write_mesh.h>

#include "file_bytes.h"
#include "surface_writers.h"
#include "text_out.h"

#include <gshell/error.h>
#include <gshell/io/atomic_file.h>


namespace gshell {

namespace io_detail {

void write_obj(std::ostream& out, const TriMesh& mesh) {
  TextOut o(out);
  o << "# gshell\n";
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) o << "v " << mesh.V(i, 0) << ' ' << mesh.V(i, 1) << ' ' << mesh.V(i, 2) << '\n';
  const bool uv = mesh.has_uv();
  if (uv)
    for (Eigen::Index i = 0; i < mesh.UV.rows(); ++i) o << "vt " << mesh.UV(i, 0) << ' ' << mesh.UV(i, 1) << '\n';
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    o << 'f';
    for (int k = 0; k < 3; ++k) {
      o << ' ' << mesh.F(f, k) + 1;
      if (uv) o << '/' << mesh.FUV(f, k) + 1;
    }
    o << '\n';
  }
}

// Vertex colors make the file COFF ("x y z r g b a"); face colors follow the indices, which plain
// OFF allows.
void write_off(std::ostream& out, const TriMesh& mesh, const MeshAttributes& a) {
  TextOut o(out);
  const bool vertex_colors = a.vertex_colors.rows() > 0, face_colors = a.face_colors.rows() > 0;
  o << (vertex_colors ? "COFF\n" : "OFF\n") << mesh.num_vertices() << ' ' << mesh.num_faces() << " 0\n";
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    o << mesh.V(i, 0) << ' ' << mesh.V(i, 1) << ' ' << mesh.V(i, 2);
    if (vertex_colors)
      o << ' ' << int(a.vertex_colors(i, 0)) << ' ' << int(a.vertex_colors(i, 1)) << ' ' << int(a.vertex_colors(i, 2))
        << " 255";
    o << '\n';
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    o << "3 " << mesh.F(f, 0) << ' ' << mesh.F(f, 1) << ' ' << mesh.F(f, 2);
    if (face_colors)
      o << ' ' << int(a.face_colors(f, 0)) << ' ' << int(a.face_colors(f, 1)) << ' ' << int(a.face_colors(f, 2));
    o << '\n';
  }
}

} // namespace io_detail

namespace {

// Inconsistent arguments are the caller's: InputError, checked before anything is written.
void check_writable(const TriMesh& mesh, const MeshAttributes& a) {
  const Eigen::Index n = mesh.V.rows(), m = mesh.F.rows();
  if (mesh.V.cols() != 3 || (m > 0 && mesh.F.cols() != 3))
    throw InputError("write_mesh: V must be n x 3 and F m x 3");
  // The readers refuse a file without vertices: what they refuse is not written either.
  if (n == 0) throw InputError("write_mesh: the mesh has no vertices");
  if (m > 0 && (mesh.F.minCoeff() < 0 || mesh.F.maxCoeff() >= n))
    throw InputError("write_mesh: face index out of range");
  if (mesh.has_uv() && (mesh.UV.cols() != 2 || mesh.FUV.cols() != 3 ||
                        (m > 0 && (mesh.FUV.minCoeff() < 0 || mesh.FUV.maxCoeff() >= mesh.UV.rows()))))
    throw InputError("write_mesh: UV must be k x 2 and FUV m x 3 with ids in range");
  if (a.vertex_colors.rows() != 0 && a.vertex_colors.rows() != n)
    throw InputError("write_mesh: vertex_colors must have one row per vertex");
  if (a.face_colors.rows() != 0 && a.face_colors.rows() != m)
    throw InputError("write_mesh: face_colors must have one row per face");
  for (const auto& [name, values] : a.vertex_scalars)
    if (values.size() != n) throw InputError("write_mesh: vertex scalar '" + name + "' needs one value per vertex");
  for (const auto& [name, values] : a.face_scalars)
    if (values.size() != m) throw InputError("write_mesh: face scalar '" + name + "' needs one value per face");
}

} // namespace

void check_mesh_output_format(const std::string& path) {
  const std::string ext = io_detail::lower_extension(path);
  if (ext == "obj" || ext == "off" || ext == "ply") return;
  const std::string why = ext == "stl" ? " (STL cannot keep the vertex order; use .obj, .off or .ply)"
                                       : " (supported for writing: .obj .off .ply)";
  throw InputError(with_file(path, "cannot write format '" + (ext.empty() ? std::string("(no extension)") : "." + ext) +
                                       "'" + why));
}

void write_mesh(const std::string& path, const TriMesh& mesh, const MeshAttributes& attributes, bool ascii_ply) {
  check_mesh_output_format(path);
  const std::string ext = io_detail::lower_extension(path);
  check_writable(mesh, attributes);
  const bool binary = ext == "ply" && !ascii_ply;
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        if (ext == "obj") io_detail::write_obj(out, mesh);
        else if (ext == "off") io_detail::write_off(out, mesh, attributes);
        else io_detail::write_ply(out, mesh, attributes, ascii_ply);
      },
      binary);
}

} // namespace gshell
