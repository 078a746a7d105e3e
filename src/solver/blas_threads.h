#pragma once
// CHOLMOD's numeric factorisation, with OpenBLAS's worker threads kept asleep when it is small.
//
// Once a threaded BLAS call wakes them, OpenBLAS's workers busy-wait (sched_yield in a loop) for
// about 2^28 cycles, some 0.1 s, before they sleep again. After a factorisation whose BLAS work
// takes a few milliseconds that spin is most of what the other cores do during the solve that
// follows (a 0.13 s hierarchical pose solve of the bowl: 0.27 against 0.19 CPU s), and it competes
// with TBB's workers for them. With one BLAS thread OpenBLAS runs the call in the caller and never
// wakes them (docs/design.md, "Speed").
#ifdef GSHELL_HAVE_CHOLMOD
#include <cholmod.h>

namespace gshell::detail {

/// Factorisations that the analysis estimates below this many flops (`cholmod_common::fl`) run
/// their BLAS calls on the calling thread: threads would save at most a few milliseconds there.
constexpr double kSerialBlasFlops = 1e8;

/// cholmod_factorize(A, L, cm) after cholmod_analyze: with OpenBLAS held to one thread for its
/// duration when cm->fl < kSerialBlasFlops (restored after; nothing changes with another BLAS,
/// found by looking `openblas_set_num_threads` up at run time). Returns cholmod_factorize's result.
/// The first call also makes OpenMP serial in processes forked after it, where GNU OpenMP's
/// thread pool would hang CHOLMOD's parallel regions.
int cholmod_factorize_small_serially(cholmod_sparse* A, cholmod_factor* L, cholmod_common* cm);

} // namespace gshell::detail
#endif
