#pragma once
// Warnings on stderr, the same for every command: "gshell COMMAND: warning: TEXT", each line in
// one write, so that a message from another thread (an interrupt's) cannot land inside one.
// Warnings are shown even with --quiet: they say something about the result.
#include <string>
#include <vector>

namespace gshell::cli {

void print_warning(const std::string& command, const std::string& text);
void print_warnings(const std::string& command, const std::vector<std::string>& texts);

} // namespace gshell::cli
