#pragma once
// Every output file is written under a temporary name next to its destination and renamed into
// place only when complete, so a failure never leaves a partial file behind.
#include <functional>
#include <ostream>
#include <string>

namespace gshell {

/// Calls write(stream) on a temporary file beside `path`, then renames it to `path`.
/// \throws InputError naming `path` when it is empty, a directory, or the file cannot be created,
///         written or moved into place; whatever `write` throws is passed on. The temporary is
///         removed on any failure.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                           bool binary = false);

} // namespace gshell
