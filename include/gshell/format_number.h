#pragma once
// Numbers in labels and messages: "%g" with a chosen precision, so 1e-20 reads as 1e-20 and not
// as std::to_string's "0.000000".
#include <cstdio>
#include <string>

namespace gshell {

/// Up to `significant` digits, no trailing zeros ("0.1", "0.0025", "12.5", "1e+20").
inline std::string format_number(double value, int significant = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", significant, value);
  return buf;
}

} // namespace gshell
