#include <gshell/io/xml_escape.h>

#include "io/utf8_code_points.h"

namespace gshell {

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  // XML 1.0 allows no control character but tab, line feed and carriage return, not even escaped.
  for (int c : utf8_code_points(text)) switch (c) {
    case '&': out += "&amp;"; break;
    case '<': out += "&lt;"; break;
    case '>': out += "&gt;"; break;
    case '"': out += "&quot;"; break;
    case '\'': out += "&apos;"; break;
    default: append_utf8(out, c < 0x20 && c != '\t' && c != '\n' && c != '\r' ? kReplacementCharacter : c);
    }
  return out;
}

} // namespace gshell
