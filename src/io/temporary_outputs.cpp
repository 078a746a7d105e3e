#include <gshell/io/temporary_outputs.h>

#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_set>

namespace gshell {

namespace fs = std::filesystem;

namespace {

struct Registry {
  std::mutex mutex;
  std::unordered_multiset<std::string> paths; // each registration counts, even of one name
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
    // Another thread may still add an entry (a frame's folder, a file opened before it was
    // registered), and the folder is then not empty when its turn comes: try again until it is
    // gone. Such a thread blocks at its next registration, so this ends.
    bool existed = false;
    for (int attempt = 0; attempt < 1000; ++attempt) {
      std::error_code ec;
      existed |= fs::remove_all(path, ec) > 0 && !ec;
      if (!fs::exists(path, ec) && !ec) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    removed += existed;
  }
  if (!for_exit) r.mutex.unlock();
  return removed;
}

} // namespace gshell
