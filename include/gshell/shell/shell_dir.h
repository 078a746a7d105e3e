#pragma once
// A shell on disk: the folder written by `gshell generate` (and read by deform, pose, render...).
#include <gshell/mesh.h>
#include <gshell/shell/shell.h>
#include <string>

namespace gshell {

/// Reads DIR/base.obj, DIR/top.obj and the thickness from DIR/report.json. Checks that both
/// surfaces have the same vertex count and faces; throws InputError naming DIR otherwise.
/// UVs of base.obj (if any) are returned in `uv_source` when it is not null.
Shell load_shell_dir(const std::string& dir, TriMesh* uv_source = nullptr);

} // namespace gshell
