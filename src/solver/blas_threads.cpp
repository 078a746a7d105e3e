#include "blas_threads.h"

#include <dlfcn.h>
#include <mutex>

namespace gshell::detail {

namespace {

// Looked up at run time: Debian chooses the BLAS behind libblas.so.3 (OpenBLAS, BLIS, the
// reference one) by alternatives, and only OpenBLAS has these.
struct OpenBlasThreads {
  using Set = void (*)(int);
  using Get = int (*)();
  Set set = reinterpret_cast<Set>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  Get get = reinterpret_cast<Get>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  bool available() const { return set && get; }
  std::mutex mutex;
  int depth = 0, saved = 1;
};

OpenBlasThreads& openblas() {
  static OpenBlasThreads threads;
  return threads;
}

} // namespace

SerialBlas::SerialBlas(bool active) : active_(active && openblas().available()) {
  if (!active_) return;
  OpenBlasThreads& b = openblas();
  std::lock_guard<std::mutex> lock(b.mutex);
  if (b.depth++ == 0) {
    b.saved = b.get();
    if (b.saved > 1) b.set(1);
  }
}

SerialBlas::~SerialBlas() {
  if (!active_) return;
  OpenBlasThreads& b = openblas();
  std::lock_guard<std::mutex> lock(b.mutex);
  if (--b.depth == 0 && b.saved > 1) b.set(b.saved);
}

} // namespace gshell::detail
