#include "text_scanner.h"

#include <gshell/error.h>

#include <array>
#include <charconv>
#include <cstdlib>
#include <limits>

namespace gshell::io_detail {

namespace {
// Byte classes, looked up once per byte in the hot loops.
enum CharClass : unsigned char { Word, Blank, Newline, Control };
constexpr auto char_classes = [] {
  std::array<CharClass, 256> t{};
  for (int c = 0; c < 256; ++c) t[c] = (c < 0x20 || c == 0x7f) ? Control : Word;
  for (unsigned char c : {' ', '\t', '\r', '\v', '\f'}) t[c] = Blank;
  t['\n'] = Newline;
  return t;
}();
CharClass class_of(char c) { return char_classes[static_cast<unsigned char>(c)]; }
} // namespace

bool parse_double(std::string_view token, double& value) {
  if (token.empty()) return false;
  std::string_view digits = token;
  if (digits.front() == '+') digits.remove_prefix(1);
  if (digits.empty() || digits.front() == '+') return false;
  const char* end = digits.data() + digits.size();
  const auto result = std::from_chars(digits.data(), end, value, std::chars_format::general);
  if (result.ptr != end) return false;
  if (result.ec == std::errc::result_out_of_range) {
    // A well-formed number beyond double's range: let strtod give +-inf or the denormal/zero,
    // so validation (not the reader) judges it, as with a literal "inf".
    const std::string copy(digits);
    value = std::strtod(copy.c_str(), nullptr);
    return true;
  }
  return result.ec == std::errc();
}

bool parse_integer(std::string_view token, long long& value) {
  if (token.empty()) return false;
  std::string_view digits = token;
  if (digits.front() == '+') digits.remove_prefix(1);
  if (digits.empty()) return false;
  const char* end = digits.data() + digits.size();
  const auto result = std::from_chars(digits.data(), end, value);
  return result.ec == std::errc() && result.ptr == end;
}

TextScanner::TextScanner(std::string_view text, std::string path, char comment, std::size_t start, int first_line)
    : text_(text), path_(std::move(path)), comment_(comment), pos_(start), line_(first_line),
      token_line_(first_line) {}

void TextScanner::check_text_byte(char c) const {
  if (class_of(c) == Control) {
    std::string where = " (line " + std::to_string(line_) + ")";
    throw InputError(with_file(path_, "unexpected binary data in a text file, not a valid mesh file?" + where));
  }
}

bool TextScanner::at_continuation() const {
  if (!continuation_ || pos_ >= text_.size() || text_[pos_] != '\\') return false;
  std::size_t p = pos_ + 1;
  while (p < text_.size() && class_of(text_[p]) == Blank) ++p;
  return p == text_.size() || text_[p] == '\n';
}

void TextScanner::skip_blanks(bool cross_lines) {
  while (pos_ < text_.size()) {
    const char c = text_[pos_];
    const CharClass k = class_of(c);
    if (k == Blank) {
      ++pos_;
    } else if (c == '\\' && at_continuation()) {
      const std::size_t end = text_.find('\n', pos_);
      if (end == std::string_view::npos) {
        pos_ = text_.size();
      } else {
        pos_ = end + 1;
        ++line_;
      }
    } else if (k == Newline) {
      if (!cross_lines) return;
      ++line_;
      ++pos_;
    } else if (comment_ != '\0' && c == comment_) {
      while (pos_ < text_.size() && text_[pos_] != '\n') check_text_byte(text_[pos_++]);
    } else {
      check_text_byte(c);
      return;
    }
  }
}

std::string_view TextScanner::next_token() {
  skip_blanks(true);
  token_line_ = line_;
  const std::size_t begin = pos_;
  while (pos_ < text_.size()) {
    const char c = text_[pos_];
    const CharClass k = class_of(c);
    if (k == Blank || k == Newline || (c == comment_ && comment_ != '\0') || (c == '\\' && at_continuation())) break;
    if (k == Control) check_text_byte(c);
    ++pos_;
  }
  return text_.substr(begin, pos_ - begin);
}

std::string_view TextScanner::next_token_on_line() {
  skip_blanks(false);
  if (pos_ >= text_.size() || text_[pos_] == '\n') return {};
  return next_token();
}

bool TextScanner::at_line_end() {
  skip_blanks(false);
  return pos_ >= text_.size() || text_[pos_] == '\n';
}

bool TextScanner::at_end() {
  skip_blanks(true);
  return pos_ >= text_.size();
}

void TextScanner::skip_rest_of_line() {
  for (bool continued = true; continued && pos_ < text_.size();) {
    continued = false; // the line's last non-blank byte is a continuation backslash
    while (pos_ < text_.size() && text_[pos_] != '\n') {
      continued = (text_[pos_] == '\\' && at_continuation()) || (continued && class_of(text_[pos_]) == Blank);
      check_text_byte(text_[pos_++]);
    }
    if (pos_ < text_.size()) {
      ++pos_;
      ++line_;
    }
  }
}

void TextScanner::fail(const std::string& what) const {
  throw InputError(with_file(path_, what + " (line " + std::to_string(token_line_) + ")"));
}

void TextScanner::fail_without_line(const std::string& what) const { throw InputError(with_file(path_, what)); }

double TextScanner::to_double(std::string_view token, const char* what) const {
  double value = 0;
  if (!parse_double(token, value)) fail(std::string("cannot read ") + what + " from '" + std::string(token.substr(0, 40)) + "'");
  return value;
}

long long TextScanner::to_integer(std::string_view token, const char* what) const {
  long long value = 0;
  if (!parse_integer(token, value)) fail(std::string("cannot read ") + what + " from '" + std::string(token.substr(0, 40)) + "'");
  return value;
}

double TextScanner::next_double(const char* what) {
  const std::string_view token = next_token();
  if (token.empty()) fail(std::string("unexpected end of file, expected ") + what + " (truncated?)");
  return to_double(token, what);
}

long long TextScanner::next_integer(const char* what) {
  const std::string_view token = next_token();
  if (token.empty()) fail(std::string("unexpected end of file, expected ") + what + " (truncated?)");
  return to_integer(token, what);
}

} // namespace gshell::io_detail
