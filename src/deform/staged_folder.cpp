#include <gshell/deform/staged_folder.h>

#include <gshell/error.h>

#include <random>
#include <system_error>

namespace gshell {

namespace fs = std::filesystem;

namespace {

fs::path sibling(const fs::path& destination, const std::string& tag) {
  std::random_device rd;
  const fs::path parent = destination.parent_path().empty() ? fs::path(".") : destination.parent_path();
  std::string name = ".";
  name += destination.filename().string();
  name += "." + tag + "-" + std::to_string(rd());
  return parent / name;
}

} // namespace

StagedFolder::StagedFolder(const fs::path& destination) : destination_(destination) {
  if (destination_.filename().empty()) destination_ = destination_.parent_path(); // "OUT/" -> "OUT"
  if (destination_.empty()) throw InputError("empty output folder name");
  const fs::path parent = destination_.parent_path().empty() ? fs::path(".") : destination_.parent_path();
  std::error_code ec;
  if (!fs::is_directory(parent, ec))
    throw InputError(with_file(destination_.string(), "parent folder does not exist"));
  if (fs::exists(destination_, ec) && !fs::is_directory(destination_, ec))
    throw InputError(with_file(destination_.string(), "exists and is not a folder"));
  staging_ = sibling(destination_, "tmp");
  if (!fs::create_directory(staging_, ec) || ec)
    throw InputError(with_file(destination_.string(), "cannot create a folder beside it: " + ec.message()));
}

StagedFolder::~StagedFolder() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

void StagedFolder::commit(const std::function<bool(const fs::path&)>& is_previous_output) {
  std::error_code ec;
  fs::path old;
  if (fs::exists(destination_, ec)) {
    const bool empty = fs::is_directory(destination_, ec) && fs::is_empty(destination_, ec);
    if (!empty && !(is_previous_output && is_previous_output(destination_)))
      throw InputError(with_file(destination_.string(), "exists and is not an earlier output of this command; "
                                                        "remove it or choose another -o"));
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
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
}

} // namespace gshell
