#pragma once
// Internal: a unit that brings a length to about 1 without rounding anything it multiplies.
#include <algorithm>
#include <cmath>

namespace gshell::detail {

/// The power of two u with size * u in [0.5, 1): multiplying by it (or dividing) is exact while
/// the result stays a normal double. 1 when size is not positive and finite.
inline double power_of_two_unit(double size) {
  if (!(size > 0) || !std::isfinite(size)) return 1;
  int exponent = 0;
  std::frexp(size, &exponent); // size = f 2^exponent, f in [0.5, 1)
  return std::ldexp(1.0, -std::clamp(exponent, -1000, 1000));
}

} // namespace gshell::detail
