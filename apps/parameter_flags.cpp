#include "parameter_flags.h"

#include <gshell/error.h>

#include <cctype>

namespace gshell::cli {

namespace {

bool word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; }

// Replaces whole words `name` in `text` by `flag`.
std::string replace_word(const std::string& text, const std::string& name, const std::string& flag) {
  std::string out;
  for (std::size_t i = 0; i < text.size();) {
    const bool starts = text.compare(i, name.size(), name) == 0 && (i == 0 || !word_char(text[i - 1])) &&
                        (i + name.size() == text.size() || !word_char(text[i + name.size()]));
    if (starts) {
      out += flag;
      i += name.size();
    } else {
      out += text[i++];
    }
  }
  return out;
}

} // namespace

void check_flags(const CLI::App& cmd, const std::function<void()>& check) {
  try {
    check();
  } catch (const InputError& e) {
    std::string message = e.what();
    for (const CLI::Option* option : cmd.get_options()) {
      for (const std::string& flag : option->get_lnames()) {
        std::string parameter = flag;
        for (char& c : parameter)
          if (c == '-') c = '_';
        message = replace_word(message, parameter, "--" + flag);
      }
    }
    throw InputError(message);
  }
}

void check_applies(const CLI::App& cmd, const std::string& flag, bool applies, const std::string& when) {
  if (!applies && cmd.get_option(flag)->count() > 0) throw InputError(flag + " applies only to " + when);
}

} // namespace gshell::cli
