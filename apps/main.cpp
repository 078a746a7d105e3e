// gshell command-line tool: a thin layer over the library. Exit codes: 0 success, 1 bad input or
// arguments, 2 internal failure.
#include "command_registry.h"
#include "interrupts.h"

#include <gshell/error.h>
#include <gshell/run/process_memory.h>

#include <algorithm>
#include <exception>
#include <iostream>
#include <string>
#include <string_view>
#include <vector>

namespace gshell::cli {
GlobalOptions& global_options() {
  static GlobalOptions options;
  return options;
}

namespace {

/// Edit distance counting insertions, deletions, substitutions and swaps of neighbours (optimal
/// string alignment): "generat" -> "generate" and "ratoi" -> "ratio" are both 1.
size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i)
    for (size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] != b[j - 1])});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

/// The candidate closest to `word`, if it is close enough to be a typo (at most a third of the
/// word's letters wrong, at least one allowed) or `word` is the start of exactly one candidate.
std::string closest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::max<size_t>(1, word.size() / 3) + 1;
  for (const auto& c : candidates)
    if (const size_t d = edit_distance(word, c); d < best_distance) best = c, best_distance = d;
  if (best.empty() && word.size() >= 2) {
    for (const auto& c : candidates)
      if (c.rfind(word, 0) == 0) {
        if (!best.empty()) return {}; // ambiguous prefix
        best = c;
      }
  }
  return best;
}

/// For a long option without a close spelling: the one option with a word (between dashes) close
/// to `name`'s, e.g. "--ratoi" -> "--thickness-ratio"; "" when none or several.
std::string option_with_word(const std::string& name, const std::vector<std::string>& options) {
  const std::string word = name.substr(2);
  if (word.size() < 3) return {};
  std::string found;
  for (const auto& o : options) {
    std::vector<std::string> words;
    for (size_t start = 2, end; start <= o.size(); start = end + 1) {
      end = std::min(o.find('-', start), o.size());
      words.push_back(o.substr(start, end - start));
    }
    if (closest(word, words).empty()) continue;
    if (!found.empty() && found != o) return {}; // ambiguous
    found = o;
  }
  return found;
}

std::string suggestion(const std::string& best) { return best.empty() ? "" : " (did you mean '" + best + "'?)"; }

/// The message for CLI11's parse error `what`: clearer than CLI11's for the two mistakes people
/// make most, a mistyped command ("A subcommand is required") and a mistyped long option ("The
/// following arguments were not expected: ..."); otherwise `what` pointing at the help of the
/// command it is about.
std::string explain_parse_error(CLI::App& app, int argc, char** argv, const std::string& what) {
  CLI::App* command = nullptr;
  std::vector<std::string> long_options; // of the parsed command (if any) and the global ones
  const auto add_long_options = [&](const CLI::App& a) {
    for (const CLI::Option* o : a.get_options())
      for (const auto& name : o->get_lnames()) long_options.push_back("--" + name);
  };
  add_long_options(app);
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") break;
    if (arg.rfind("--", 0) == 0) {
      const std::string name = arg.substr(0, arg.find('='));
      if (app.get_option_no_throw(name) || (command && command->get_option_no_throw(name))) continue;
      std::string best = closest(name, long_options);
      if (best.empty()) best = option_with_word(name, long_options);
      const std::string where = command ? " for '" + command->get_name() + "'" : "";
      const std::string help = command ? "gshell " + command->get_name() + " --help" : "gshell --help";
      return "unknown option '" + name + "'" + where + (best.empty() ? " (see " + help + ")" : suggestion(best));
    }
    if (command || arg.empty() || arg[0] == '-') continue; // an operand or a short option
    const auto named = app.get_subcommands([&](CLI::App* c) { return c->check_name(arg); });
    if (named.empty()) {
      std::vector<std::string> names;
      for (const CLI::App* c : app.get_subcommands({})) names.push_back(c->get_name());
      const std::string best = closest(arg, names);
      return "unknown command '" + arg + "'" + (best.empty() ? " (see gshell --help for the commands)" : suggestion(best));
    }
    command = named.front();
    add_long_options(*command);
  }
  std::string message = what;
  // CLI11's "Could not convert: --steps = 99999999999999" says neither what is wrong nor the range.
  if (const std::string prefix = "Could not convert: "; what.rfind(prefix, 0) == 0) {
    std::string rest = what.substr(prefix.size());
    const auto eq = rest.find(" = ");
    const std::string name = rest.substr(0, eq);
    if (eq != std::string::npos) rest.replace(eq, 3, " ");
    const CLI::Option* option = command ? command->get_option_no_throw(name) : nullptr;
    if (!option) option = app.get_option_no_throw(name);
    const std::string type = option ? option->get_type_name() : "";
    // The bound on the side the value went past (counts are refused below 0 next anyway).
    const std::string value = eq == std::string::npos ? std::string() : what.substr(prefix.size() + eq + 3);
    const bool whole = !value.empty() && value.find_first_not_of("+-0123456789") == std::string::npos;
    const std::string int_range = !whole             ? ": expected a whole number"
                                  : value[0] == '-' ? ": expected a whole number of at least -2147483648"
                                                    : ": expected a whole number of at most 2147483647";
    message = rest + (type == "INT" ? int_range : type == "FLOAT" ? ": expected a number" : ": not a value this option takes");
  }
  // CLI11's "--thickness-ratio: At Most 1 required but received 2": an option given twice.
  if (const std::string marker = ": At Most 1 required but received "; what.find(marker) != std::string::npos) {
    const auto at = what.find(marker);
    message = what.substr(0, at) + " is given " + what.substr(at + marker.size()) + " times (once at most)";
  }
  return message + " (see gshell " + (command ? command->get_name() + " " : "") + "--help)";
}

} // namespace
} // namespace gshell::cli

int main(int argc, char** argv) {
  using namespace gshell::cli;
  gshell::restart_with_serial_blas_under_address_limit(argv);
  gshell::restart_with_huge_pages(argv); // where the kernel gives them only on request
  gshell::reuse_freed_memory(); // one command per process: keep freed buffers for the next phase
  catch_interrupts();
  CLI::App app{"gshell: build and deform shells (Huang et al. 2007, gradient-based shell generation "
               "and deformation)."};
  app.set_version_flag("--version", std::string("gshell ") + GSHELL_VERSION);
  app.require_subcommand(1);
  app.fallthrough();
  app.add_flag("-q,--quiet", global_options().quiet, "No progress output on stderr");
  auto list = commands();
  std::sort(list.begin(), list.end(), [](const Command& a, const Command& b) { return a.order < b.order; });
  for (const auto& c : list) c.add(app);
  try {
    try {
      app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
      return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
      return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
      return app.exit(e);
    } catch (const CLI::ParseError& e) {
      std::cerr << ("gshell: error: " + explain_parse_error(app, argc, argv, e.what()) + "\n");
      return 1;
    }
  } catch (const gshell::InputError& e) {
    wait_if_interrupted();
    std::cerr << ("gshell: error: " + std::string(e.what()) + "\n");
    return 1;
  } catch (const std::bad_alloc&) {
    wait_if_interrupted();
    // A limit of the machine more often than a fault of the program: said as such.
    std::cerr << "gshell: error: out of memory (the job needs more memory than the system gave)\n";
    return 2;
  } catch (const std::exception& e) {
    wait_if_interrupted();
    std::cerr << ("gshell: internal error: " + std::string(e.what()) + "\n");
    return 2;
  } catch (...) {
    wait_if_interrupted();
    std::cerr << "gshell: internal error: unknown exception\n";
    return 2;
  }
  return 0;
}
