#pragma once
// Which instruction set the hot kernels run with: the batched 3x3 polar decompositions, the
// solver's local step and the per-tet stretch are compiled for AVX-512, AVX2 + FMA and baseline
// x86-64 (SSE2) alike, and pick the best one the CPU supports when they run. So one build runs
// on any x86-64 and is fast where the CPU is. Other CPUs (or compilers without per-function
// targets) have only Generic.
#include <string>

namespace gshell {

enum class SimdLevel {
  Generic, ///< baseline instructions of the build (SSE2 on x86-64)
  Avx2,    ///< AVX2 + FMA, 4 doubles per register
  Avx512,  ///< AVX-512 F/DQ/VL + FMA, 8 doubles per register
};

/// The level the kernels use: simd_level_supported(), capped by the environment variable
/// GSHELL_SIMD (generic, avx2 or avx512; read at the first call; other values are ignored) and
/// by set_simd_level.
SimdLevel simd_level();

/// The best level this CPU and this build support.
SimdLevel simd_level_supported();

/// Makes every kernel use `level` from now on (all threads): for tests and A/B benchmarks in one
/// process. Results agree across levels to round-off (fused multiply-adds round differently).
/// \throws InputError if `level` is above simd_level_supported().
void set_simd_level(SimdLevel level);

/// "generic", "avx2", "avx512".
std::string to_string(SimdLevel level);

/// Inverse of to_string. \throws InputError naming the unknown value.
SimdLevel parse_simd_level(const std::string& name);

} // namespace gshell
