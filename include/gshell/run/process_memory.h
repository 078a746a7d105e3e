#pragma once
// Memory policy for processes that run one job and exit (the CLI, the benchmarks).
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

} // namespace gshell
