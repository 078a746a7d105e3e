#pragma once
// Memory policy for processes that run one job and exit (the CLI, the benchmarks).
#include <string>

namespace gshell {

/// Keeps memory the process frees for its next allocations instead of returning it to the
/// operating system. glibc maps every block above its threshold (at most 32 MB) afresh and unmaps
/// it when freed, so each phase of a generation on millions of faces (rest tets, trees, face data:
/// hundreds of MB each) faults in and zeroes every page of its buffers again; at builtin:sphere:9
/// that was 4.9M page faults for a 6.4 GB peak (docs/scale.md). Afterwards no block is mapped on
/// its own and the heap is never trimmed: the process keeps its peak footprint, and every later
/// phase reuses pages it has already touched. All threads share one arena (glibc gives threads
/// arenas of their own, so a tree a worker thread built after the solver was freed took fresh
/// pages beside the freed ones: 0.4 GB at sphere:9).
/// Call once, early (threads started before keep their arenas), in a process whose footprint may
/// stay at its peak until it exits; not from a library inside a long-lived host. Does nothing
/// where the C library is not glibc.
void reuse_freed_memory();

/// Restarts the process once, with the same arguments (`execv` of /proc/self/exe), with glibc's
/// malloc told to ask for transparent huge pages for its heap (`GLIBC_TUNABLES` gains
/// `glibc.malloc.hugetlb=1`), where the kernel gives huge pages only to memory that asks for them
/// (transparent_hugepage "madvise" mode, the default of Ubuntu among others; "always" needs no
/// asking). Why: a generation on millions of vertices walks gigabytes of tets, trees and matrices
/// every iteration; in 4 KB pages that is a TLB miss per few tets and a page fault per 4 KB on first
/// touch, both far dearer in a virtual machine. At builtin:sphere:9 (3.4 GB) huge pages took the
/// faults from 0.87 M to 6 K and an iteration from 1.7 to 1.2 s (docs/scale.md).
/// Returns without restarting where it cannot help or would surprise: not Linux with glibc 2.35 or
/// later; the mode is not "madvise"; `GLIBC_TUNABLES` already names glibc.malloc.hugetlb (so a
/// restarted process does not restart again, and `GLIBC_TUNABLES=glibc.malloc.hugetlb=0` opts
/// out); the process runs under valgrind (whose restarted child would run untraced); or the
/// restart fails. Call first thing in `main`, before any thread or output; for one-job processes
/// (the CLI, the benchmarks), not from a library inside a host.
void restart_with_huge_pages(char** argv);

/// Under an address-space limit (`ulimit -v`, as batch systems and some containers set), restarts
/// the process once, as restart_with_huge_pages does, with `OPENBLAS_NUM_THREADS=1`. OpenBLAS
/// started with several threads maps a 128 MB buffer on a thread's first call, and where that
/// mapping fails it retries forever: a generation of bunny00 that fits in 400 MB spun until killed
/// (its main thread's buffer, after the job's own memory; setting the thread count later does not
/// help), where with one thread from the start it runs in 0.9 s, and a job that does not fit fails
/// with the out-of-memory error instead of a hang. Returns without restarting without a limit,
/// when `OPENBLAS_NUM_THREADS` is set already (also what keeps a restarted process from
/// restarting), under valgrind, or when the restart fails. Call first thing in `main`.
void restart_with_serial_blas_under_address_limit(char** argv);

/// The kernel's transparent huge page mode ("always", "madvise" or "never", the bracketed word of
/// /sys/kernel/mm/transparent_hugepage/enabled); "" where there is no such file.
std::string transparent_huge_page_mode();

} // namespace gshell
