#pragma once
// Readers parse whole files held in memory: simple bounds checks, and every count a header
// claims can be compared with the bytes that are really there before anything is allocated.
#include <cstddef>
#include <string>
#include <string_view>

namespace gshell::io_detail {

/// A file's bytes, read-only. A regular file is mapped rather than copied: copying a shell.vtu of
/// 256 MB into fresh memory cost more than parsing it (every page of the copy is faulted in and
/// zeroed first). Other files (pipes, /dev/stdin) and empty ones are read into memory.
/// The mapping assumes nobody truncates the file while it is read (gshell itself only ever
/// replaces files by renaming a finished one over them, which leaves a mapping intact).
class FileBytes {
public:
  /// Throws InputError "PATH: ..." when the file is missing, a folder or unreadable.
  explicit FileBytes(const std::string& path);
  ~FileBytes();
  FileBytes(const FileBytes&) = delete;
  FileBytes& operator=(const FileBytes&) = delete;

  std::string_view view() const { return map_ ? std::string_view(map_, size_) : std::string_view(copy_); }
  operator std::string_view() const { return view(); }

private:
  const char* map_ = nullptr;
  std::size_t size_ = 0;
  std::string copy_;
};

/// Throws InputError "PATH: no such file" or "PATH: is a directory, expected a mesh file": the
/// checks FileBytes makes first, for readers that look at a path before opening it (its format).
void require_file(const std::string& path);

/// Lower-cased extension without the dot ("mesh.PLY" -> "ply"); empty when there is none.
std::string lower_extension(const std::string& path);

} // namespace gshell::io_detail
