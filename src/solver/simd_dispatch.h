#pragma once
// Run-time dispatch of the hot SIMD kernels (see gshell/solver/simd_level.h).
//
// A kernel body is written once, as plain loops over SIMD lanes, and marked GSHELL_SIMD_KERNEL
// (always inlined). GSHELL_SIMD_DISPATCH compiles it three times in the same translation unit,
// inlined into functions carrying per-function target attributes (AVX-512, AVX2 + FMA, baseline),
// and defines a function that calls the variant for simd_level(). Why this way:
// - The translation unit itself is compiled for baseline x86-64, so every Eigen type has one
//   layout across the library, and every out-of-line function (Eigen's, the standard library's,
//   ours) is baseline code: nothing that a baseline CPU could reach holds an AVX instruction.
//   Per-ISA translation units would break that: inline functions they instantiate (Eigen's,
//   std::'s) are merged by the linker with the baseline copies, and the AVX-512 copy may win.
// - Only code inlined into a variant gets its instruction set; a call the compiler does not
//   inline stays baseline (slower, still correct). Bodies therefore avoid Eigen's explicit
//   vectorisation (fixed at compile time to SSE2) in their hot loops and use plain loops that
//   the compiler vectorises for each target.
// - One dispatch per call of a body (a chunk of thousands of tets, or a batch of rotations):
//   the cost of choosing is negligible.
#include <gshell/solver/simd_level.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define GSHELL_SIMD_X86 1
#if defined(__clang__)
#define GSHELL_TARGET_AVX512 __attribute__((target("avx512f,avx512dq,avx512vl,fma")))
#else
// GCC: also use full 512-bit registers (its default tuning prefers 256-bit pieces).
#define GSHELL_TARGET_AVX512 __attribute__((target("avx512f,avx512dq,avx512vl,fma,prefer-vector-width=512")))
#endif
#define GSHELL_TARGET_AVX2 __attribute__((target("avx2,fma")))
#else
#define GSHELL_SIMD_X86 0
#endif

#define GSHELL_SIMD_KERNEL inline __attribute__((always_inline))

#if GSHELL_SIMD_X86
/// Defines `static RET NAME PARAMS` running `BODY ARGS` compiled for simd_level(). PARAMS and ARGS
/// are parenthesised lists: (const double* a, int n) and (a, n).
#define GSHELL_SIMD_DISPATCH(RET, NAME, BODY, PARAMS, ARGS)                                                        \
  GSHELL_TARGET_AVX512 static RET NAME##_avx512 PARAMS { return BODY ARGS; }                                   \
  GSHELL_TARGET_AVX2 static RET NAME##_avx2 PARAMS { return BODY ARGS; }                                       \
  static RET NAME##_generic PARAMS { return BODY ARGS; }                                                       \
  static RET NAME PARAMS {                                                                                     \
    switch (::gshell::simd_level()) {                                                                          \
    case ::gshell::SimdLevel::Avx512: return NAME##_avx512 ARGS;                                              \
    case ::gshell::SimdLevel::Avx2: return NAME##_avx2 ARGS;                                                  \
    default: return NAME##_generic ARGS;                                                                      \
    }                                                                                                          \
  }
#else
#define GSHELL_SIMD_DISPATCH(RET, NAME, BODY, PARAMS, ARGS)                                                        \
  static RET NAME PARAMS { return BODY ARGS; }
#endif
