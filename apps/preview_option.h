#pragma once
// `--render [--view V]`: a preview.png rendered inside the output folder before it is moved into
// place, shared by generate, deform and pose.
#include <gshell/render/camera.h>
#include <gshell/run/shell_folder.h>

#include <CLI/CLI.hpp>
#include <string>

namespace gshell::cli {

/// InputError when gshell was built without OSMesa (checked before any work).
void require_renderer();

/// Adds --render (described by `what`: what preview.png shows) and --view (needs --render) to `cmd`.
void add_preview_flags(CLI::App& cmd, bool& render, std::string& view, const std::string& what);

/// The checked --view (an InputError naming the flag) and, with --render, require_renderer(): a
/// bad preview request fails before any work.
ViewDirection check_preview_flags(const CLI::App& cmd, bool render, const std::string& view);

/// Renders DIR/preview.png into the staged folder (captions name `output`), or nothing when
/// `render` is false.
BeforeCommit preview_writer(bool render, const std::string& output, const ViewDirection& view = {});

} // namespace gshell::cli
