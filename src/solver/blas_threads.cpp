#include "blas_threads.h"

#ifdef GSHELL_HAVE_CHOLMOD
#include <dlfcn.h>
#include <mutex>
#include <pthread.h>

namespace gshell::detail {

namespace {

// Looked up at run time: Debian chooses the BLAS behind libblas.so.3 (OpenBLAS, BLIS, the
// reference one) by alternatives, and only OpenBLAS has these.
struct OpenBlasThreads {
  using Set = void (*)(int);
  using Get = int (*)();
  Set set = reinterpret_cast<Set>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  Get get = reinterpret_cast<Get>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  std::mutex mutex;
  int depth = 0, saved = 1;
};

OpenBlasThreads& openblas() {
  static OpenBlasThreads threads;
  return threads;
}

// One BLAS thread while alive. Factorisations may overlap across threads: the first to enter
// sets one thread, the last to leave restores the count found.
class SerialBlas {
public:
  explicit SerialBlas(bool active) : active_(active && openblas().set && openblas().get) {
    if (!active_) return;
    OpenBlasThreads& b = openblas();
    std::lock_guard<std::mutex> lock(b.mutex);
    if (b.depth++ == 0) {
      b.saved = b.get();
      if (b.saved > 1) b.set(1);
    }
  }
  ~SerialBlas() {
    if (!active_) return;
    OpenBlasThreads& b = openblas();
    std::lock_guard<std::mutex> lock(b.mutex);
    if (--b.depth == 0 && b.saved > 1) b.set(b.saved);
  }
  SerialBlas(const SerialBlas&) = delete;
  SerialBlas& operator=(const SerialBlas&) = delete;

private:
  bool active_;
};

// CHOLMOD runs parts of its supernodal factorisation in OpenMP parallel regions. GNU OpenMP's
// thread pool does not survive fork(): in a child (Python multiprocessing's default start on
// Linux) the first parallel region waits for the parent's pool threads, which the child does not
// have, and hangs for good. With no active levels a region runs on its calling thread alone and
// leaves the pool be, so a child inherits a working, if serial, CHOLMOD.
using SetMaxActiveLevels = void (*)(int);
SetMaxActiveLevels set_max_active_levels = nullptr; // found in the parent: dlsym is not for a fork handler

void openmp_serial_in_child() {
  if (set_max_active_levels) set_max_active_levels(0);
}

void keep_openmp_usable_after_fork() {
  static std::once_flag registered;
  std::call_once(registered, [] {
    set_max_active_levels = reinterpret_cast<SetMaxActiveLevels>(dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
    if (set_max_active_levels) pthread_atfork(nullptr, nullptr, openmp_serial_in_child);
  });
}

} // namespace

int cholmod_factorize_small_serially(cholmod_sparse* A, cholmod_factor* L, cholmod_common* cm) {
  keep_openmp_usable_after_fork();
  const SerialBlas serial(cm->fl < kSerialBlasFlops);
  return cholmod_factorize(A, L, cm);
}

} // namespace gshell::detail
#endif
