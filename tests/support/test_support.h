#pragma once
// Helpers shared by the test executables: running the CLI, temporary folders.
#include <filesystem>
#include <string>

namespace gshell::test {

struct CliResult {
  int exit_code = -1;
  std::string out; ///< stdout
  std::string err; ///< stderr
};

/// Runs build/bin/gshell with `args` (a shell-quoted string) and captures its output.
CliResult run_cli(const std::string& args);

/// A fresh empty folder under the system temp dir, removed when the object dies.
class TempDir {
public:
  explicit TempDir(const std::string& tag = "gshell-test");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

private:
  std::filesystem::path path_;
};

/// Writes `content` to `path` verbatim (binary).
void write_text(const std::string& path, const std::string& content);
std::string read_text(const std::string& path);

/// Number of entries in a folder (to check that failed commands leave nothing behind).
int count_entries(const std::filesystem::path& dir);

} // namespace gshell::test
