#pragma once
// Readers parse whole files held in memory: simple bounds checks, and every count a header
// claims can be compared with the bytes that are really there before anything is allocated.
#include <string>

namespace gshell::io_detail {

/// The file's bytes. Throws InputError "PATH: ..." when it is missing, a folder or unreadable.
std::string read_file_bytes(const std::string& path);

/// Lower-cased extension without the dot ("mesh.PLY" -> "ply"); empty when there is none.
std::string lower_extension(const std::string& path);

} // namespace gshell::io_detail
