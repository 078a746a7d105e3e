#include "warnings.h"

#include <iostream>

namespace gshell::cli {

void print_warning(const std::string& command, const std::string& text) {
  std::cerr << ("gshell " + command + ": warning: " + text + "\n"); // one insertion is one write
}

void print_warnings(const std::string& command, const std::vector<std::string>& texts) {
  for (const std::string& text : texts) print_warning(command, text);
}

} // namespace gshell::cli
