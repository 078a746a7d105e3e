#pragma once
// Every output file is written under a temporary name next to its destination and renamed into
// place only when complete, so a failure never leaves a partial file behind.
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>

namespace gshell {

/// Where an output named `path` goes, through a symbolic link: written whole beside `path` and
/// renamed onto it, a file or folder would replace the link itself (an `out -> /scratch/out` link
/// lost, the output on the other disk). Returns `path` when it is not a link.
std::filesystem::path output_target(const std::filesystem::path& path);

/// The check every output makes before any work: the folder it goes into exists and is a folder.
/// \throws InputError naming `output`: "parent folder does not exist" or "parent P is not a folder".
void check_output_parent(const std::filesystem::path& output);

/// Removes what runs killed outright (kill -9, the out-of-memory killer, a CI timeout) left beside
/// `destination`: its temporaries and staging folders (".NAME.tmp-PID-..."), and folders set aside
/// while replacing it (".NAME.old-PID-..."), whose process no longer exists on this machine. They
/// are hidden and can hold hundreds of MB. Those of a live process, and other names, are left.
/// StagedFolder calls it before it stages; the CLI, for each output file, before the work. Not
/// write_file_atomically: files written into a fresh staging folder have nothing beside them to
/// clean, and a scan of the folder per file made animate's 10,000 frames take 27 s instead of 1-3.
void remove_orphans_of(const std::filesystem::path& destination);

/// Calls write(stream) on a temporary file beside `path` (beside its target where it is a
/// symbolic link: output_target), then renames it there.
/// \throws InputError naming `path` when it is empty, a directory, or the file cannot be created,
///         written or moved into place; whatever `write` throws is passed on. The temporary is
///         removed on any failure.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write,
                           bool binary = false);

} // namespace gshell
