#pragma once
#include <gshell/mesh.h>
#include <string>

namespace gshell {

/// Reads OBJ, OFF (also COFF/NOFF), PLY (ASCII, binary little/big endian) or STL (ASCII/binary),
/// chosen by the file extension (case-insensitive). Polygons are fan-triangulated; OBJ `vt`
/// texture coordinates are kept in UV/FUV. Vertex order is the file's.
/// Throws InputError ("PATH: problem") on a missing file, unknown format or malformed content.
/// Does not validate the mesh (see validate_mesh.h).
TriMesh read_mesh(const std::string& path);

} // namespace gshell
