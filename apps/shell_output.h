#pragma once
// Writing a shell folder (what `gshell generate` produces and load_shell_dir reads) without ever
// leaving a partial result: everything goes to a temporary folder beside DIR first.
#include <gshell/mesh.h>
#include <gshell/quality/shell_metrics.h>
#include <gshell/shell/shell.h>

#include <nlohmann/json.hpp>
#include <string>

namespace gshell::cli {

/// Throws InputError if `dir` exists and is not a folder, or its parent folder does not exist.
void check_output_dir(const std::string& dir);

/// Writes DIR/top.obj (the top with the input's faces, vertex order and UVs), DIR/base.obj (the
/// input as used), DIR/shell.vtu (2n points, 3m tets; cell data stretch, inverted, prism) and
/// DIR/report.json. Files are complete in a temporary folder before any is moved into DIR.
void write_shell_dir(const std::string& dir, const TriMesh& base, const Shell& shell, const ShellMetrics& metrics,
                     const nlohmann::json& report);

} // namespace gshell::cli
