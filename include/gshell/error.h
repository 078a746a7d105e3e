#pragma once
// Exceptions of the library. The CLI maps InputError to exit code 1 and anything else to 2.
#include <stdexcept>
#include <string>

namespace gshell {

/// Bad input or bad parameters: a file that cannot be read, a mesh that cannot carry a shell,
/// an impossible option. The message is one line that names the file (if any) and the problem.
class InputError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// Formats "FILE: problem" (or just "problem" when no file is involved).
inline std::string with_file(const std::string& file, const std::string& problem) {
  return file.empty() ? problem : file + ": " + problem;
}

} // namespace gshell
