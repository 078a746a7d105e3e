#include <gshell/solver/simd_level.h>

#include <gshell/error.h>

#include "solver/simd_dispatch.h"

#include <atomic>
#include <algorithm>
#include <cstdlib>

namespace gshell {

namespace {

SimdLevel detect() {
#if GSHELL_SIMD_X86
  // libgcc / compiler-rt check the OS saves the wide registers (XCR0) before reporting AVX*.
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl") &&
      __builtin_cpu_supports("fma"))
    return SimdLevel::Avx512;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return SimdLevel::Avx2;
#endif
  return SimdLevel::Generic;
}

SimdLevel initial_level() {
  SimdLevel level = simd_level_supported();
  if (const char* cap = std::getenv("GSHELL_SIMD")) {
    try {
      level = std::min(level, parse_simd_level(cap));
    } catch (const InputError&) {
      // an unknown value caps nothing (benchmarks print the level they ran with)
    }
  }
  return level;
}

std::atomic<SimdLevel>& current() {
  static std::atomic<SimdLevel> level{initial_level()};
  return level;
}

} // namespace

SimdLevel simd_level_supported() {
  static const SimdLevel supported = detect();
  return supported;
}

SimdLevel simd_level() { return current().load(std::memory_order_relaxed); }

void set_simd_level(SimdLevel level) {
  if (level > simd_level_supported())
    throw InputError("SIMD level " + to_string(level) + " is not supported here (at most " +
                     to_string(simd_level_supported()) + ")");
  current().store(level, std::memory_order_relaxed);
}

std::string to_string(SimdLevel level) {
  switch (level) {
  case SimdLevel::Avx512: return "avx512";
  case SimdLevel::Avx2: return "avx2";
  default: return "generic";
  }
}

SimdLevel parse_simd_level(const std::string& name) {
  for (SimdLevel level : {SimdLevel::Generic, SimdLevel::Avx2, SimdLevel::Avx512})
    if (name == to_string(level)) return level;
  throw InputError("unknown SIMD level '" + name + "' (expected generic, avx2 or avx512)");
}

} // namespace gshell
