#pragma once
// Keeping OpenBLAS's worker threads asleep through small factorisations.
//
// Once a threaded BLAS call wakes them, OpenBLAS's workers busy-wait (sched_yield in a loop) for
// about 2^28 cycles, some 0.1 s, before they sleep again. After a factorisation whose BLAS work
// takes a few milliseconds that spin is most of what the other cores do during the solve that
// follows (a 0.13 s hierarchical pose solve of the bowl: 0.27 against 0.19 CPU s), and it competes
// with TBB's workers for them. With one BLAS thread OpenBLAS runs the call in the caller and never
// wakes them (docs/design.md, "Speed").
namespace gshell::detail {

/// Factorisations estimated below this many flops (CHOLMOD's analysis, `cholmod_common::fl`) run
/// their BLAS calls on the calling thread: threads would save at most a few milliseconds there.
constexpr double kSerialBlasFlops = 1e8;

/// While alive (and `active`), BLAS calls run on the calling thread only. Does nothing when the
/// BLAS in use is not OpenBLAS (no `openblas_set_num_threads` in the process). Scopes may nest and
/// overlap across threads: the first to enter sets one thread, the last to leave restores the
/// count found.
class SerialBlas {
public:
  explicit SerialBlas(bool active = true);
  ~SerialBlas();
  SerialBlas(const SerialBlas&) = delete;
  SerialBlas& operator=(const SerialBlas&) = delete;

private:
  bool active_;
};

} // namespace gshell::detail
