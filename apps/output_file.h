#pragma once
// Checks of a command's output file, made before any work: its name says what it holds, and
// writing it destroys no input.
#include <string>
#include <vector>

namespace gshell::cli {

/// \throws InputError naming `output` when its extension is not `extension` (".html",
/// case-insensitive; "" for any: the writer checks it), when it is one of `inputs` (the same
/// file, by any path), or when it is a file a gshell output folder is read from
/// (is_output_folder_file): `gshell report DIR -o DIR/report.json` replaced the report it was made
/// from, `texture -o DIR/top.obj` the shell's top.
void check_output_file(const std::string& output, const std::string& extension, const std::vector<std::string>& inputs);

/// The extension of `path` with its dot, lower-cased ("x.PLY" -> ".ply"; "" when none).
std::string lower_extension(const std::string& path);

} // namespace gshell::cli
