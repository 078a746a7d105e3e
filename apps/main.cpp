// gshell command-line tool: a thin layer over the library. Exit codes: 0 success, 1 bad input or
// arguments, 2 internal failure.
#include "command_registry.h"

#include <gshell/error.h>

#include <algorithm>
#include <exception>
#include <iostream>

namespace gshell::cli {
GlobalOptions& global_options() {
  static GlobalOptions options;
  return options;
}
} // namespace gshell::cli

int main(int argc, char** argv) {
  using namespace gshell::cli;
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
      std::cerr << "gshell: error: " << e.what() << " (see gshell --help)\n";
      return 1;
    }
  } catch (const gshell::InputError& e) {
    std::cerr << "gshell: error: " << e.what() << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "gshell: internal error: out of memory\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "gshell: internal error: " << e.what() << "\n";
    return 2;
  } catch (...) {
    std::cerr << "gshell: internal error: unknown exception\n";
    return 2;
  }
  return 0;
}
