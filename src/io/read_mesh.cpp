// Surface readers: OBJ, OFF, PLY and STL, all parsed by our own code (read_obj.cpp, read_off.cpp,
// read_ply.cpp, read_stl.cpp) over the whole file held in memory.
//
// Why not a library reader: we checked the Debian candidates against what gshell needs, which is
// (1) the file's vertex order, (2) OBJ `vt`, and (3) one clear error "PATH: what (line N)" on
// malformed input, never a crash, a hang or a huge allocation.
// - CGAL 5.5 (CGAL::IO::read_OFF/read_PLY/read_STL/read_OBJ into a polygon soup) keeps vertex
//   order, but only answers true/false and prints to std::cerr (no line, no reason). On hostile
//   input it sizes containers from untrusted counts: read_PLY resizes a face list to the count in
//   the file before reading it (a count of 4e9 -> std::bad_alloc, i.e. 16 GB asked for),
//   read_OFF resizes its arrays to the header's counts before reading (and binary OFF faces to
//   their claimed sizes); read_PLY accepts out-of-range face indices; read_STL's ASCII parser rejects "nan" and then silently re-reads the text as binary
//   STL, returning garbage points; its corner merging keys a std::map on Point_3, whose ordering
//   is undefined for NaN. read_OBJ drops `vt`.
// - tinyobjloader (libtinyobjloader-dev, not installed by default) keeps `vt` but turns
//   unparsable numbers into 0 silently and ignores unknown lines, so garbage reads as a mesh.
// These formats are small; a reader that checks every count against the bytes really present
// before allocating, and every index against the vertex count, is a few hundred lines, and gives
// the messages users need. NaN/inf coordinates are read as such: validate_mesh reports them.
#include <gshell/io/read_mesh.h>

#include "file_bytes.h"
#include "surface_readers.h"

#include <gshell/error.h>

namespace gshell {

TriMesh read_mesh(const std::string& path, std::vector<std::string>* warnings, std::vector<std::string>* skipped) {
  const std::string ext = io_detail::lower_extension(path);
  if (ext != "obj" && ext != "off" && ext != "ply" && ext != "stl") {
    // A mistyped or missing folder (no extension) is missing, not a file of an unknown format.
    io_detail::require_file(path);
    throw InputError(with_file(path, "unknown mesh format '" + (ext.empty() ? std::string("(no extension)") : "." + ext) +
                                         "' (supported: .obj .off .ply .stl)"));
  }
  const io_detail::FileBytes bytes(path);
  if (ext == "obj") return io_detail::read_obj(path, bytes, warnings, skipped);
  if (ext == "off") return io_detail::read_off(path, bytes, skipped);
  if (ext == "ply") return io_detail::read_ply(path, bytes, skipped);
  return io_detail::read_stl(path, bytes);
}

} // namespace gshell
