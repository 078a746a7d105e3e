#pragma once
// One writer per surface format, each writing to an already opened (temporary) stream.
#include <gshell/io/write_mesh.h>

#include <ostream>

namespace gshell::io_detail {

void write_obj(std::ostream& out, const TriMesh& mesh);
void write_off(std::ostream& out, const TriMesh& mesh, const MeshAttributes& attributes);
void write_ply(std::ostream& out, const TriMesh& mesh, const MeshAttributes& attributes, bool ascii);

} // namespace gshell::io_detail
