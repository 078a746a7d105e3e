#pragma once
// Buffered text output for the ASCII writers. Doubles are written in the shortest form that reads
// back to the same value (std::to_chars), so positions survive a write/read round trip exactly.
#include <charconv>
#include <ostream>
#include <string>
#include <string_view>

namespace gshell::io_detail {

class TextOut {
public:
  explicit TextOut(std::ostream& out) : out_(out) { buffer_.reserve(capacity + 64); }
  ~TextOut() { flush(); }
  TextOut(const TextOut&) = delete;
  TextOut& operator=(const TextOut&) = delete;

  TextOut& operator<<(std::string_view s) {
    buffer_.append(s);
    maybe_flush();
    return *this;
  }
  TextOut& operator<<(char c) {
    buffer_.push_back(c);
    maybe_flush();
    return *this;
  }
  TextOut& operator<<(double v) { return number(v); }
  TextOut& operator<<(long long v) { return number(v); }
  TextOut& operator<<(int v) { return number(v); }
  TextOut& operator<<(unsigned v) { return number(v); }
  void flush() {
    out_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

private:
  static constexpr std::size_t capacity = 1 << 20;
  template <class T>
  TextOut& number(T v) {
    char text[64];
    const auto r = std::to_chars(text, text + sizeof(text), v);
    buffer_.append(text, r.ptr);
    maybe_flush();
    return *this;
  }
  void maybe_flush() {
    if (buffer_.size() >= capacity) flush();
  }
  std::ostream& out_;
  std::string buffer_;
};

} // namespace gshell::io_detail
