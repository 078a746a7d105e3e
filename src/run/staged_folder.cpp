#include <gshell/run/staged_folder.h>

#include <gshell/error.h>
#include <gshell/io/atomic_file.h>
#include <gshell/run/frames.h>

#include "run/output_folder_files.h"

#include <algorithm>
#include <random>
#include <string>
#include <system_error>
#include <vector>

#include <unistd.h>

namespace gshell {

namespace fs = std::filesystem;

namespace {

fs::path parent_of(const fs::path& destination) {
  return destination.parent_path().empty() ? fs::path(".") : destination.parent_path();
}

// ".NAME.TAG-PID-RANDOM": the process id tells a later run whether the folder's owner is gone.
fs::path sibling(const fs::path& destination, const std::string& tag) {
  std::random_device rd;
  std::string name = ".";
  name += destination.filename().string();
  name += "." + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(rd());
  return parent_of(destination) / name;
}

// Why no folder could be made beside `destination` (`ec` from making it), for the user.
InputError cannot_write_beside(const fs::path& destination, const std::error_code& ec) {
  // /proc and the like answer "No such file or directory" for a folder that exists.
  std::error_code parent_ec;
  const bool parent_exists = fs::is_directory(parent_of(destination), parent_ec);
  const std::string why = ec == std::errc::no_such_file_or_directory && parent_exists
                              ? "its file system does not allow new folders"
                              : ec.message();
  return InputError(
      with_file(destination.string(), "cannot write in " + parent_of(destination).string() + ": " + why));
}

fs::path folder_name(const fs::path& destination) {
  fs::path d = destination;
  // "OUT/." and "." name a folder by its own entry: its staging folder must go beside it, not into
  // it (where the check for other files found it), so the name it is known by comes first.
  if (const std::string last = d.filename().string(); last == "." || last == "..") {
    std::error_code ec;
    d = fs::absolute(d, ec).lexically_normal();
    if (ec) throw InputError(with_file(destination.string(), "the current folder cannot be found (" + ec.message() + ")"));
  }
  if (d.filename().empty()) d = d.parent_path(); // "OUT/" -> "OUT"
  if (d.empty()) throw InputError("empty output folder name");
  return d;
}

bool replaceable(const fs::path& destination, const std::function<bool(const fs::path&)>& is_previous_output) {
  std::error_code ec;
  if (!fs::exists(destination, ec)) return true;
  const bool empty = fs::is_directory(destination, ec) && fs::is_empty(destination, ec);
  return empty || (is_previous_output && is_previous_output(destination));
}

// Entries no gshell command writes into its output folders (a report.html, a render put beside
// the shell), named in the message: the folder may well be this command's earlier output
// otherwise, and the user should not have to guess what holds it back.
std::vector<std::string> foreign_entries(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const bool ours = is_shell_file(name) || name == kPreviewFile || frame_number(name) || frame_number(name, ".obj");
    if (!ours) out.push_back(name);
  }
  std::sort(out.begin(), out.end());
  return out;
}

InputError not_replaceable(const fs::path& destination) {
  const std::vector<std::string> foreign = foreign_entries(destination);
  if (foreign.empty())
    return InputError(with_file(destination.string(), "exists and is not an earlier output of this command; "
                                                      "remove it or choose another output folder"));
  std::string names;
  for (std::size_t k = 0; k < std::min<std::size_t>(foreign.size(), 3); ++k) names += (k ? ", " : "") + foreign[k];
  if (foreign.size() > 3) names += " and " + std::to_string(foreign.size() - 3) + " more";
  return InputError(with_file(destination.string(), "exists and holds files gshell does not write there (" + names +
                                                        "), which replacing the folder would delete; move them, "
                                                        "remove the folder or choose another output folder"));
}

// check_output_folder's checks of the path and what is there, without making anything (a
// StagedFolder makes its staging folder next, which is the test of writing there).
void check_destination(const fs::path& d, const std::function<bool(const fs::path&)>& is_previous_output) {
  check_output_parent(d);
  std::error_code ec;
  if (fs::exists(d, ec) && !fs::is_directory(d, ec)) throw InputError(with_file(d.string(), "exists and is not a folder"));
  // The output replaces the folder as a whole: the current folder, or one holding it, would be
  // taken from under the user's shell.
  const fs::path here = fs::current_path(ec);
  if (!ec && fs::exists(d, ec)) {
    const fs::path out = fs::weakly_canonical(fs::absolute(d), ec);
    if (!ec) {
      if (std::mismatch(out.begin(), out.end(), here.begin(), here.end()).first == out.end())
        throw InputError(with_file(d.string(), "is the current folder or holds it, and the output replaces its folder "
                                               "as a whole; choose a folder inside it"));
    }
  }
  if (is_previous_output && !replaceable(d, is_previous_output)) throw not_replaceable(d);
}

} // namespace

void check_output_folder(const fs::path& destination, const std::function<bool(const fs::path&)>& is_previous_output) {
  const fs::path d = folder_name(destination);
  check_destination(d, is_previous_output);
  // A run of minutes must not end in "cannot write": its staging folder is made (and removed) now.
  // Named as one, so that a run killed in between has it removed by the next.
  std::error_code ec;
  const fs::path probe = sibling(output_target(d), "tmp");
  if (!fs::create_directory(probe, ec) || ec) throw cannot_write_beside(output_target(d), ec);
  fs::remove(probe, ec);
}

StagedFolder::StagedFolder(const fs::path& destination) : destination_(output_target(folder_name(destination))) {
  check_destination(destination_, {});
  remove_orphans_of(destination_);
  std::error_code ec;
  staging_ = sibling(destination_, "tmp");
  if (!fs::create_directory(staging_, ec) || ec) throw cannot_write_beside(destination_, ec);
  registered_.emplace(staging_);
}

std::string StagedFolder::at_destination(std::string message) const {
  const std::string from = staging_.string(), to = destination_.string();
  for (std::size_t at = message.find(from); at != std::string::npos; at = message.find(from, at + to.size()))
    message.replace(at, from.size(), to);
  return message;
}

StagedFolder::~StagedFolder() {
  if (!registered_) return; // committed
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

void StagedFolder::commit(const std::function<bool(const fs::path&)>& is_previous_output) {
  std::error_code ec;
  fs::path old;
  if (fs::exists(destination_, ec)) {
    if (!replaceable(destination_, is_previous_output)) throw not_replaceable(destination_);
    old = sibling(destination_, "old");
    fs::rename(destination_, old, ec);
    if (ec) throw InputError(with_file(destination_.string(), "cannot replace it: " + ec.message()));
  }
  fs::rename(staging_, destination_, ec);
  if (ec) {
    std::error_code ignored;
    if (!old.empty()) fs::rename(old, destination_, ignored);
    throw InputError(with_file(destination_.string(), "cannot move the output into place: " + ec.message()));
  }
  registered_.reset(); // committed: no longer temporary
  if (!old.empty()) fs::remove_all(old, ec);
}

} // namespace gshell
