#include "blas_threads.h"

#ifdef GSHELL_HAVE_CHOLMOD
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

} // namespace

int cholmod_factorize_small_serially(cholmod_sparse* A, cholmod_factor* L, cholmod_common* cm) {
  const SerialBlas serial(cm->fl < kSerialBlasFlops);
  return cholmod_factorize(A, L, cm);
}

} // namespace gshell::detail
#endif
