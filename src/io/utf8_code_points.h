#pragma once
// Text from users (file names, captions, JSON strings) is bytes; where it must be UTF-8 (XML, a
// font's glyphs) each malformed byte stands for one U+FFFD, as browsers show it.
#include <string>
#include <vector>

namespace gshell {

inline constexpr int kReplacementCharacter = 0xFFFD;

/// Unicode code points of `text` read as UTF-8; a byte that does not start a complete sequence
/// becomes kReplacementCharacter and reading goes on at the next byte.
std::vector<int> utf8_code_points(const std::string& text);

/// `code_point` (0 to 0x10FFFF) appended to `out` as UTF-8.
void append_utf8(std::string& out, int code_point);

} // namespace gshell
