// read_mesh, write_mesh, builtin, weld.
#include "bindings.h"
#include "numpy_arrays.h"

#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/geometry/weld_vertices.h>
#include <gshell/io/load_mesh.h>
#include <gshell/io/write_mesh.h>

#include <pybind11/stl/filesystem.h>

#include <filesystem>

namespace gshell::python {

namespace {

py::tuple mesh_tuple(const TriMesh& mesh) { return py::make_tuple(from_matrix(mesh.V), from_indices(mesh.F)); }

py::tuple read_mesh_py(const std::filesystem::path& path) {
  TriMesh mesh;
  {
    ReleasedGil release;
    mesh = read_mesh_or_builtin(path.string());
    // As `gshell convert` does: a NaN read from a file is named there, not later as an array index.
    require_usable_coordinates(mesh.V, path.string());
  }
  return mesh_tuple(mesh);
}

void write_mesh_py(const std::filesystem::path& path, const ArrayArg& V, const ArrayArg& F) {
  TriMesh mesh;
  mesh.V = to_positions(V, "V");
  mesh.F = to_indices(F, "F", 3, static_cast<int>(mesh.V.rows()));
  ReleasedGil release;
  write_mesh(path.string(), mesh);
}

py::tuple builtin_py(const std::string& spec) {
  const std::string full = is_builtin_spec(spec) ? spec : "builtin:" + spec;
  TriMesh mesh;
  {
    ReleasedGil release;
    mesh = make_builtin(full);
  }
  return mesh_tuple(mesh);
}

py::tuple weld_py(const ArrayArg& V, const ArrayArg& F) {
  TriMesh mesh;
  mesh.V = to_positions(V, "V");
  mesh.F = to_indices(F, "F", 3, static_cast<int>(mesh.V.rows()));
  {
    ReleasedGil release;
    mesh = weld_boundary_vertices(mesh);
  }
  return mesh_tuple(mesh);
}

} // namespace

void bind_io(py::module_& m) {
  m.def("read_mesh", &read_mesh_py, py::arg("path"),
        R"(Read a triangle mesh: OBJ, OFF, PLY (ASCII or binary) or STL, by file extension, or a
"builtin:NAME[:RES]" spec as the command line takes it (the same as builtin()).

Polygons are fan-triangulated; the vertex order of the file is kept.

Args:
    path: file path (str or os.PathLike).

Returns:
    (V, F): float64 array (n, 3) of positions and int64 array (m, 3) of vertex ids.

Raises:
    ValueError: missing file, unknown format, malformed content (the message names the file
        and, for text formats, the line), or a coordinate that is NaN, infinite or of 1e50 or
        more (the message names the file and the vertex).)");

  m.def("write_mesh", &write_mesh_py, py::arg("path"), py::arg("V"), py::arg("F"),
        R"(Write a triangle mesh as OBJ, OFF or PLY (binary), by file extension.

The file is written atomically (temporary file, then rename); the vertex order is kept.

Args:
    path: output file (str or os.PathLike); .obj, .off or .ply.
    V: float array (n, 3), finite, every |x| < 1e50.
    F: integer array (m, 3) of vertex ids in [0, n).

Raises:
    ValueError: wrong shapes or dtypes, NaN, indices out of range, unknown extension or an
        unwritable path.)");

  m.def("builtin", &builtin_py, py::arg("spec"),
        R"(Build one of gshell's built-in meshes (no files needed).

Args:
    spec: "NAME[:RES]" or "builtin:NAME[:RES]", NAME one of sphere (RES = subdivision level,
        default 4), torus (segments around, default 64), plane (quads per side, default 32),
        cylinder (segments around, default 64), bowl (rings, default 40). Same specs as the CLI.

Returns:
    (V, F): float64 array (n, 3) and int64 array (m, 3); faces are counter-clockwise seen from
    outside.

Raises:
    ValueError: unknown name or resolution out of range.)");

  m.def("weld", &weld_py, py::arg("V"), py::arg("F"),
        R"(Join a surface's cuts, as `gshell convert --weld` does.

A boundary vertex (on an edge of one face) at exactly the position of a lower-numbered boundary
vertex (a triangle soup, seams split by an exporter) is replaced by it and removed; the other
vertices keep their order, the faces theirs. generate() lists such cuts in its report's
`warnings`, because the shell lines a cut with walls that touch.

Args:
    V: float array (n, 3).
    F: integer array (m, 3) of vertex ids in [0, n).

Returns:
    (V, F): the welded mesh (not validated: joining two patches that touch at one corner makes a
    non-manifold vertex, which generate() then refuses).

Raises:
    ValueError: wrong shapes or dtypes, indices out of range.)");
}

} // namespace gshell::python
