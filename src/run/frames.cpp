#include <gshell/run/frames.h>

#include <gshell/error.h>
#include <gshell/run/shell_folder.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <string>

namespace gshell {

namespace fs = std::filesystem;

std::string frame_name(int k, const std::string& extension, int count) {
  // One width for the whole sequence, so that a shell's glob (frame_*.obj) lists it in order.
  const int width = std::max(4, static_cast<int>(std::to_string(std::max(count, 0)).size()));
  char name[32];
  std::snprintf(name, sizeof name, "frame_%0*d", width, k);
  return name + extension;
}

std::optional<int> frame_number(const std::string& name, const std::string& extension) {
  static const std::string prefix = "frame_";
  // Any number of digits: gshell writes at least four, other tools and users fewer (frame_2.obj).
  if (name.size() < prefix.size() + 1 + extension.size() || name.compare(0, prefix.size(), prefix) != 0)
    return std::nullopt;
  // The extension in any case, as every reader takes it (frame_0001.OBJ from another tool).
  for (std::size_t i = 0; i < extension.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(name[name.size() - extension.size() + i])) != extension[i])
      return std::nullopt;
  const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - extension.size());
  if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
    return std::nullopt;
  return std::stoi(digits);
}

std::vector<fs::path> list_frames(const fs::path& dir, const std::string& extension) {
  std::vector<std::pair<int, fs::path>> found;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (extension.empty() ? !entry.is_directory(ec) : !entry.is_regular_file(ec)) continue;
    if (const auto k = frame_number(entry.path().filename().string(), extension)) found.emplace_back(*k, entry.path());
  }
  std::sort(found.begin(), found.end());
  for (std::size_t k = 1; k < found.size(); ++k)
    if (found[k].first == found[k - 1].first)
      throw InputError(with_file(dir.string(), found[k - 1].second.filename().string() + " and " +
                                                   found[k].second.filename().string() + " are both frame " +
                                                   std::to_string(found[k].first) + "; keep one of them"));
  std::vector<fs::path> frames;
  for (auto& [k, path] : found) frames.push_back(std::move(path));
  return frames;
}

std::vector<std::string> expand_frame_arguments(const std::vector<std::string>& arguments) {
  std::vector<std::string> frames;
  for (const std::string& argument : arguments) {
    std::error_code ec;
    if (!fs::is_directory(argument, ec)) {
      frames.push_back(argument);
      continue;
    }
    std::vector<fs::path> found;
    for (const char* extension : {".obj", ".off", ".ply", ".stl"})
      if (found.empty()) found = list_frames(argument, extension);
    if (found.empty())
      throw InputError(argument + ": a folder holding no frame files (frame_0001.obj .., as gshell animate writes; "
                                  "frames named otherwise are given as files, e.g. " +
                       (fs::path(argument) / "*.obj").string() + ")" +
                       (is_shell_folder(argument) ? "; it is a shell folder: give " +
                                                        (fs::path(argument) / "base.obj").string() + " for its base"
                                                  : std::string()));
    for (const fs::path& path : found) frames.push_back(path.string());
  }
  return frames;
}

} // namespace gshell
