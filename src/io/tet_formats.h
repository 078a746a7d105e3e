#pragma once
// One writer/reader pair per tet mesh format; tet_mesh_io.cpp picks by extension.
#include <gshell/io/tet_mesh_io.h>

#include <ostream>
#include <string_view>

namespace gshell::io_detail {

void write_vtu(std::ostream& out, const TetMesh& mesh);
TetMesh read_vtu(const std::string& path, std::string_view bytes);

void write_medit(std::ostream& out, const TetMesh& mesh);
TetMesh read_medit(const std::string& path, std::string_view bytes);

} // namespace gshell::io_detail
