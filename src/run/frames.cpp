#include <gshell/run/frames.h>

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
  if (name.size() < prefix.size() + 4 + extension.size() || name.compare(0, prefix.size(), prefix) != 0 ||
      name.compare(name.size() - extension.size(), extension.size(), extension) != 0)
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
  std::vector<fs::path> frames;
  for (auto& [k, path] : found) frames.push_back(std::move(path));
  return frames;
}

} // namespace gshell
