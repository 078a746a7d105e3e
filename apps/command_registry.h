#pragma once
// Subcommands register themselves here, one apps/cmd_<name>.cpp each, so adding a subcommand
// never touches main.cpp.
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace gshell::cli {

struct Command {
  int order;                                     ///< position in `gshell --help`
  std::function<void(CLI::App& parent)> add;     ///< adds the subcommand and its callback
};

inline std::vector<Command>& commands() {
  static std::vector<Command> list;
  return list;
}

/// Use at namespace scope: `static const CommandRegistrar reg{20, add_generate_command};`
struct CommandRegistrar {
  CommandRegistrar(int order, std::function<void(CLI::App&)> add) {
    commands().push_back({order, std::move(add)});
  }
};

/// Global flags shared by subcommands that run long.
struct GlobalOptions {
  bool quiet = false;
};
GlobalOptions& global_options();

} // namespace gshell::cli
