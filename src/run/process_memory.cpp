#include <gshell/run/process_memory.h>

#include <climits> // also brings glibc's <features.h>, which defines __GLIBC__

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace gshell {

void reuse_freed_memory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, -1); // never trim: -1 turns trimming off
  // One arena for all threads: a block a worker thread asks for then comes from the heap where
  // the main thread's freed buffers are, not from fresh pages of an arena of its own.
  mallopt(M_ARENA_MAX, 1);
#endif
}

} // namespace gshell
