#include <gshell/io/temporary_outputs.h>

#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_set>

namespace gshell {

namespace fs = std::filesystem;

namespace {

struct Registry {
  std::mutex mutex;
  std::unordered_multiset<std::string> paths; // a name may be registered twice (a folder reused)
};

// Never destroyed: a signal thread may use it while the main thread runs static destructors.
Registry& registry() {
  static Registry* r = new Registry;
  return *r;
}

} // namespace

TemporaryOutput::TemporaryOutput(fs::path path) : path_(std::move(path)) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  r.paths.insert(path_.string());
}

TemporaryOutput::~TemporaryOutput() {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  if (const auto it = r.paths.find(path_.string()); it != r.paths.end()) r.paths.erase(it);
}

int remove_temporary_outputs(bool for_exit) noexcept {
  Registry& r = registry();
  r.mutex.lock();
  int removed = 0;
  for (const std::string& path : r.paths) {
    std::error_code ec;
    const std::uintmax_t count = fs::remove_all(path, ec);
    removed += !ec && count > 0;
  }
  if (!for_exit) r.mutex.unlock();
  return removed;
}

} // namespace gshell
