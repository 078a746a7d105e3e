// reuse_freed_memory: a large block the process frees stays in its heap for the next allocation
// (glibc would otherwise have mapped it on its own and unmapped it at free). restart_with_huge_pages:
// a restarted process's heap is in huge pages. restart_with_serial_blas_under_address_limit: a
// process under an address-space limit restarts with one BLAS thread. Its own executable: the
// calls change the allocator of the whole process.
#include <gshell/run/process_memory.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <utility>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#endif
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__) && defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 35))
#define GSHELL_TEST_HUGE_PAGES 1
#include <fstream>
#endif

namespace {

#if defined(__linux__)
/// Forks a child that runs `prepare` (its environment, its limits), then `restart` and, if that
/// returns, restarts itself unchanged; returns the exit status of the process that results, which
/// a check of its own (before gtest starts) decides.
int status_of_restarted(const std::function<void()>& prepare, void (*restart)(char**)) {
  const pid_t pid = fork();
  if (pid == 0) {
    prepare();
    char self[] = "process_memory_test";
    char* argv[] = {self, nullptr};
    restart(argv);
    execv("/proc/self/exe", argv);
    _exit(5);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
#endif

#if defined(GSHELL_TEST_HUGE_PAGES)
constexpr const char* kChildVariable = "GSHELL_HUGE_PAGE_CHILD"; // "1": expect huge pages, "0": none

/// Kilobytes of this process's anonymous memory in transparent huge pages.
long anon_huge_page_kb() {
  std::ifstream rollup("/proc/self/smaps_rollup");
  const std::string key = "AnonHugePages:";
  for (std::string line; std::getline(rollup, line);)
    if (line.rfind(key, 0) == 0) return std::stol(line.substr(key.size()));
  return -1;
}

/// The restarted test's own process: before gtest starts, it touches 64 MB of heap and exits 0 if
/// huge pages back it as expected, 3 if not (the parent test reads the exit status).
const bool kRanAsChild = [] {
  const char* expect = std::getenv(kChildVariable);
  if (!expect) return false;
  gshell::reuse_freed_memory(); // as the CLI: every block from the heap
  constexpr std::size_t kBlock = std::size_t{64} << 20;
  static char* volatile block; // volatile: the stores below must happen
  block = static_cast<char*>(std::malloc(kBlock));
  if (!block) _exit(4);
  std::memset(block, 1, kBlock);
  const long kb = anon_huge_page_kb();
  std::fprintf(stderr, "child (expecting %s): AnonHugePages %ld kB\n", expect, kb);
  _exit((std::strcmp(expect, "1") == 0 ? kb >= static_cast<long>(kBlock >> 11) : kb == 0) ? 0 : 3); // half the block, in kB
}();

/// A child that sets GLIBC_TUNABLES to `tunables` (nullptr: unset) and calls restart_with_huge_pages.
int status_of_restarted_child(const char* tunables, const char* expect) {
  return status_of_restarted(
      [&] {
        if (tunables) setenv("GLIBC_TUNABLES", tunables, 1);
        else unsetenv("GLIBC_TUNABLES");
        setenv(kChildVariable, expect, 1);
      },
      gshell::restart_with_huge_pages);
}

// Where the kernel gives huge pages only on request, the restarted process's heap asks for them;
// a GLIBC_TUNABLES that already names the setting (here: off) is left alone and nothing restarts.
TEST(ProcessMemory, RestartGivesTheHeapHugePagesUnlessTheUserChoseOtherwise) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer has its own allocator";
#endif
  if (const std::string mode = gshell::transparent_huge_page_mode(); mode != "madvise")
    GTEST_SKIP() << "transparent huge pages are '" << mode << "' here, not 'madvise'";
  EXPECT_FALSE(kRanAsChild);
  EXPECT_EQ(status_of_restarted_child(nullptr, "1"), 0);
  EXPECT_EQ(status_of_restarted_child("glibc.malloc.check=0", "1"), 0) << "other tunables are kept beside it";
  EXPECT_EQ(status_of_restarted_child("glibc.malloc.hugetlb=0", "0"), 0);
}
#endif

#if defined(__GLIBC__)
TEST(ProcessMemory, AFreedLargeBlockStaysInTheHeap) {
  constexpr std::size_t kBlock = std::size_t{64} << 20; // above glibc's largest mmap threshold
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer has its own allocator: glibc's heap statistics say nothing";
#endif
  // Allocates, touches and frees one block; returns the bytes of mapped blocks the free gave
  // back and the free bytes left in the heap.
  auto free_a_block = [&] {
    void* block = std::malloc(kBlock);
    EXPECT_NE(block, nullptr);
    std::memset(block, 1, kBlock);
    const std::size_t mapped_before = mallinfo2().hblkhd;
    std::free(block);
    return std::pair<std::size_t, std::size_t>{mapped_before - mallinfo2().hblkhd, mallinfo2().fordblks};
  };
  EXPECT_GE(free_a_block().first, kBlock) << "glibc's default maps such a block on its own";
  gshell::reuse_freed_memory();
  const auto [unmapped, free_in_heap] = free_a_block();
  EXPECT_EQ(unmapped, 0u);
  EXPECT_GE(free_in_heap, kBlock);
}

// A block another thread asks for after the main thread freed a larger one comes from the freed
// one's place (with glibc's default that thread gets an arena of its own, elsewhere, and touches
// fresh pages). Threads started before reuse_freed_memory keep their arenas: none is here.
TEST(ProcessMemory, AnotherThreadReusesAFreedBlock) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer has its own allocator";
#endif
  gshell::reuse_freed_memory();
  constexpr std::size_t kFreed = std::size_t{32} << 20, kAsked = std::size_t{16} << 20;
  void* freed = std::malloc(kFreed);
  ASSERT_NE(freed, nullptr);
  std::memset(freed, 1, kFreed);
  const auto begin = reinterpret_cast<std::uintptr_t>(freed);
  std::free(freed);
  std::uintptr_t asked = 0;
  std::thread([&] {
    void* block = std::malloc(kAsked);
    asked = reinterpret_cast<std::uintptr_t>(block);
    std::free(block);
  }).join();
  EXPECT_GE(asked, begin);
  EXPECT_LE(asked + kAsked, begin + kFreed);
}
#endif

#if defined(__linux__)
constexpr const char* kBlasChildVariable = "GSHELL_SERIAL_BLAS_CHILD"; // the OPENBLAS_NUM_THREADS expected, "-": unset

/// The restarted test's own process: exits 0 if OPENBLAS_NUM_THREADS is as its parent expects, 3
/// if not.
const bool kRanAsBlasChild = [] {
  const char* expect = std::getenv(kBlasChildVariable);
  if (!expect) return false;
  const char* threads = std::getenv("OPENBLAS_NUM_THREADS");
  _exit(std::string(threads ? threads : "-") == expect ? 0 : 3);
}();

/// A child that sets OPENBLAS_NUM_THREADS to `threads` (nullptr: unset) and, with `limit`, an
/// address-space limit of 64 GB, and calls restart_with_serial_blas_under_address_limit.
int status_of_blas_child(bool limit, const char* threads, const char* expect) {
  return status_of_restarted(
      [&] {
        if (threads) setenv("OPENBLAS_NUM_THREADS", threads, 1);
        else unsetenv("OPENBLAS_NUM_THREADS");
        setenv(kBlasChildVariable, expect, 1);
        const rlimit as{rlim_t{64} << 30, rlim_t{64} << 30};
        if (limit && setrlimit(RLIMIT_AS, &as) != 0) _exit(6);
      },
      gshell::restart_with_serial_blas_under_address_limit);
}

// Under an address-space limit the process restarts with OpenBLAS held to one thread (with
// several, a buffer mapping that fails makes it retry forever: bunny00's generation spun under a
// 400 MB limit it fits in); a thread count the user set, or no limit, is left alone.
TEST(ProcessMemory, AnAddressSpaceLimitRestartsWithOneBlasThreadUnlessTheUserChose) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves its shadow memory beyond any address-space limit";
#endif
  EXPECT_FALSE(kRanAsBlasChild);
  EXPECT_EQ(status_of_blas_child(true, nullptr, "1"), 0);
  EXPECT_EQ(status_of_blas_child(true, "2", "2"), 0);
  EXPECT_EQ(status_of_blas_child(false, nullptr, "-"), 0);
}
#endif

} // namespace
