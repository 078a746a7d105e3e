#pragma once
// Outputs still being written by this process (temporary files and staging folders), so that a
// program ending on a signal can remove them first. Everything gshell writes goes under a
// temporary name and is renamed into place when complete; a process killed in between would
// otherwise leave the temporary behind (a deform of bunny00 stopped after a second left 53 MB in
// a hidden folder). The CLI removes them on Ctrl-C and SIGTERM (apps/interrupts.h).
#include <filesystem>

namespace gshell {

/// Registers `path` for as long as the object lives. It does not remove the path itself: its
/// owner removes it on failure or renames it into place (write_file_atomically, StagedFolder).
class TemporaryOutput {
public:
  explicit TemporaryOutput(std::filesystem::path path);
  ~TemporaryOutput();
  TemporaryOutput(const TemporaryOutput&) = delete;
  TemporaryOutput& operator=(const TemporaryOutput&) = delete;

private:
  std::filesystem::path path_;
};

/// Removes every registered path (folders with their contents) and returns how many existed.
/// With `for_exit`, the registry stays locked afterwards, so another thread still writing blocks at
/// its next file instead of writing into a removed folder: for a thread about to end the process.
/// Safe from any thread, not from a signal handler (it takes a mutex and allocates).
int remove_temporary_outputs(bool for_exit = false) noexcept;

} // namespace gshell
