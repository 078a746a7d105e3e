#pragma once
// A line-aware tokenizer for the ASCII formats (OBJ, OFF, ASCII PLY/STL, MEDIT). It knows the
// current line so every error can say where it is, and it refuses control bytes so a binary or
// corrupted file is reported as such instead of being half-parsed.
#include <string>
#include <string_view>

namespace gshell::io_detail {

class TextScanner {
public:
  /// `comment`: character starting a comment that runs to the end of the line ('\0' = none).
  TextScanner(std::string_view text, std::string path, char comment = '#', std::size_t start = 0,
              int first_line = 1);

  /// Joins a line ending in a backslash (blanks after it allowed) to the next one, as OBJ's
  /// specification allows for long statements: the backslash and the line end read as a blank.
  void allow_line_continuation() { continuation_ = true; }

  /// Next token, crossing line ends; empty at the end of the input.
  std::string_view next_token();
  /// Next token on the current line; empty when the line (or input) ends.
  std::string_view next_token_on_line();
  /// True when nothing but blanks and a comment remain on the current line.
  bool at_line_end();
  /// True when nothing but blanks and comments remain in the input.
  bool at_end();
  /// Moves past the end of the current line, ignoring whatever is left on it.
  void skip_rest_of_line();

  /// Line of the last token returned (1-based).
  int line() const { return token_line_; }
  std::size_t position() const { return pos_; }
  const std::string& path() const { return path_; }

  /// Throws InputError "PATH: what (line N)".
  [[noreturn]] void fail(const std::string& what) const;
  /// Throws InputError "PATH: what" (for problems not tied to a line).
  [[noreturn]] void fail_without_line(const std::string& what) const;

  /// Parses a whole token as a number; "nan"/"inf" are accepted (validation reports them),
  /// anything else that is not a number throws with `what` and the line.
  double to_double(std::string_view token, const char* what) const;
  long long to_integer(std::string_view token, const char* what) const;

  /// next_token() that must exist and be a number.
  double next_double(const char* what);
  long long next_integer(const char* what);

private:
  void skip_blanks(bool cross_lines);
  void check_text_byte(char c) const;
  /// With continuation allowed: whether pos_ is a backslash with only blanks after it on its line.
  bool at_continuation() const;

  std::string_view text_;
  std::string path_;
  char comment_;
  bool continuation_ = false;
  std::size_t pos_;
  int line_;
  int token_line_;
};

/// Number parsing shared with the binary formats' ASCII headers; false when `token` is not
/// entirely a number.
bool parse_double(std::string_view token, double& value);
bool parse_integer(std::string_view token, long long& value);

} // namespace gshell::io_detail
