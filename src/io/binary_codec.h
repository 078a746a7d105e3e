#pragma once
// Fixed-size little/big endian values in byte buffers, for PLY, STL and VTU.
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>

namespace gshell::io_detail {

template <class T>
T byteswapped(T value) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  std::memcpy(&value, b, sizeof(T));
  return value;
}

/// Reads a T stored with the given byte order at `data` (no alignment needed).
template <class T>
T load_value(const char* data, bool big_endian) {
  static_assert(std::is_trivially_copyable_v<T>);
  T value;
  std::memcpy(&value, data, sizeof(T));
  const bool native_big = std::endian::native == std::endian::big;
  return big_endian == native_big ? value : byteswapped(value);
}

/// Appends a T in little-endian byte order.
template <class T>
void append_little_endian(std::string& out, T value) {
  static_assert(std::is_trivially_copyable_v<T>);
  if constexpr (std::endian::native == std::endian::big) value = byteswapped(value);
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  out.append(b, sizeof(T));
}

} // namespace gshell::io_detail
