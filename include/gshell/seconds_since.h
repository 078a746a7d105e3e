#pragma once
// Wall-clock time for reports and progress lines (monotonic: never jumps with the system clock).
// Include it from source files only: files that keep their own helper of this name in an anonymous
// namespace would otherwise see two.
#include <chrono>

namespace gshell {

/// Seconds elapsed since `start` on std::chrono::steady_clock.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

} // namespace gshell
