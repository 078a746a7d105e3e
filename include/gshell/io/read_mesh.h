#pragma once
#include <gshell/mesh.h>
#include <string>
#include <vector>

namespace gshell {

/// Reads OBJ, OFF (also COFF/NOFF), PLY (ASCII, binary little/big endian) or STL (ASCII/binary),
/// chosen by the file extension (case-insensitive). Polygons are fan-triangulated; OBJ `vt`
/// texture coordinates are kept in UV/FUV (only when every face has them). Vertex order is the
/// file's; STL corners with equal coordinates become one vertex, numbered by first appearance.
/// \throws InputError ("PATH: problem (line N)") on a missing file, unknown format or malformed
/// content: unparsable numbers, out-of-range indices, counts that do not match the data (also data
/// left over after the announced elements), binary files of the wrong length.
/// Does not validate the mesh (see validate_mesh.h): NaN/inf coordinates are read as they are.
/// `warnings` (if not null) receives "PATH: ..." lines for what is read past: an OBJ's texture
/// coordinates dropped because only some faces have them. `skipped` (if not null) receives, once
/// each, names of the data the file holds that a TriMesh does not keep: "vertex colors",
/// "normals", "face colors", "materials", OFF's "texture coordinates", a PLY's other properties
/// ("vertex property 'nx'") and elements ("'edge' elements"). STL's facet normals and attribute
/// bytes are not named: every STL file has them. At most 16 names.
TriMesh read_mesh(const std::string& path, std::vector<std::string>* warnings = nullptr,
                  std::vector<std::string>* skipped = nullptr);

} // namespace gshell
