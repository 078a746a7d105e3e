#include <gshell/run/process_memory.h>

#include <climits> // also brings glibc's <features.h>, which defines __GLIBC__
#include <fstream>

#include <cstdlib>
#include <cstring>

#if defined(__linux__)
#include <sys/resource.h>
#include <unistd.h>
#endif

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__) && defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 35))
#define GSHELL_GLIBC_HUGE_PAGES 1 // glibc 2.35 brought the glibc.malloc.hugetlb tunable
#endif

namespace gshell {

namespace {

bool under_valgrind() {
  const char* preload = std::getenv("LD_PRELOAD"); // valgrind runs its client with its own preload library
  return preload && std::strstr(preload, "vgpreload");
}

#if defined(__linux__)
// Runs this program again, same arguments, with `name` set to `value`; returns only when that
// fails, with the environment as it was (`before`: the variable's earlier value, or null).
void restart_with_variable(const char* name, const std::string& value, const char* before, char** argv) {
  const std::string kept = before ? before : "";
  if (setenv(name, value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  if (before) setenv(name, kept.c_str(), 1);
  else unsetenv(name);
}
#endif

} // namespace

void reuse_freed_memory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, -1); // never trim: -1 turns trimming off
  // One arena for all threads: a block a worker thread asks for then comes from the heap where
  // the main thread's freed buffers are, not from fresh pages of an arena of its own.
  mallopt(M_ARENA_MAX, 1);
#endif
}

void restart_with_huge_pages(char** argv) {
#if defined(GSHELL_GLIBC_HUGE_PAGES)
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (tunables && std::strstr(tunables, "glibc.malloc.hugetlb")) return;
  if (under_valgrind()) return; // an exec would leave valgrind behind
  if (transparent_huge_page_mode() != "madvise") return;
  const std::string before = tunables ? tunables : "";
  restart_with_variable("GLIBC_TUNABLES", (before.empty() ? "" : before + ":") + "glibc.malloc.hugetlb=1", tunables,
                        argv);
#else
  (void)argv;
#endif
}

void restart_with_serial_blas_under_address_limit(char** argv) {
#if defined(__linux__)
  rlimit limit{};
  if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return;
  if (std::getenv("OPENBLAS_NUM_THREADS") || under_valgrind()) return;
  restart_with_variable("OPENBLAS_NUM_THREADS", "1", nullptr, argv);
#else
  (void)argv;
#endif
}

std::string transparent_huge_page_mode() {
  std::string line;
  std::getline(std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled"), line);
  const size_t open = line.find('['), close = line.find(']', open);
  return open == std::string::npos || close == std::string::npos ? "" : line.substr(open + 1, close - open - 1);
}

} // namespace gshell
