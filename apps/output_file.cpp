#include "output_file.h"

#include <gshell/error.h>
#include <gshell/io/atomic_file.h>
#include <gshell/run/shell_folder.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

namespace gshell::cli {

namespace fs = std::filesystem;

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

void check_output_file(const std::string& output, const std::string& extension, const std::vector<std::string>& inputs) {
  const std::string ext = lower_extension(output);
  if (!extension.empty() && ext != extension)
    throw InputError(with_file(output, "the output is written as " + extension.substr(1) + ": give it a " + extension +
                                           " name"));
  std::error_code ec;
  // Where the file cannot go, said before the work rather than after it (curvature of bunny00
  // with wide rings ran 7 s and then found no such folder).
  check_output_parent(output);
  if (fs::is_directory(output, ec)) throw InputError(with_file(output, "is a directory, expected a file name"));
  for (const std::string& input : inputs)
    if (fs::equivalent(output, input, ec))
      throw InputError(with_file(output, "is an input of this command (" + input + "); write the output elsewhere"));
  if (is_output_folder_file(output))
    throw InputError(with_file(output, "is a file of a gshell output folder, which this command would break; write "
                                       "the output elsewhere"));
  remove_orphans_of(output_target(output)); // what runs killed outright left beside this output
}

} // namespace gshell::cli
