#include "geometry/first_touch.h"

#include <sys/mman.h>
#include <unistd.h>

#include <tbb/parallel_for.h>

#include <cstdint>

namespace gshell::detail {

void populate_in_parallel(void* data, std::size_t bytes) {
#ifdef MADV_POPULATE_WRITE
  constexpr std::size_t kMinBytes = std::size_t{8} << 20; // below it one thread is as quick
  constexpr std::size_t kChunk = std::size_t{16} << 20;
  if (!data || bytes < kMinBytes) return;
  const std::uintptr_t page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  // Whole pages inside the buffer only: the pages it shares with neighbours are faulted in by
  // the first write as usual.
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + page - 1) / page * page;
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) / page * page;
  if (end <= begin) return;
  const std::size_t chunks = (end - begin + kChunk - 1) / kChunk;
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    const std::uintptr_t a = begin + c * kChunk;
    const std::uintptr_t b = a + kChunk < end ? a + kChunk : end;
    // Failure (an old kernel: EINVAL) leaves the pages to be faulted in by the first write.
    madvise(reinterpret_cast<void*>(a), b - a, MADV_POPULATE_WRITE);
  });
#else
  (void)data;
  (void)bytes;
#endif
}

} // namespace gshell::detail
