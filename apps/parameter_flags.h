#pragma once
// The library names parameters (`steps must be >= 1`); the CLI user knows them as flags
// (`--steps`). check_flags runs a library check and names the flags in its message.
#include <CLI/CLI.hpp>
#include <functional>

namespace gshell::cli {

/// Runs `check`; an InputError it throws is rethrown with every parameter name that is one of
/// `cmd`'s long flags (s_min -> --s-min) written as that flag. Only for checks of parameters:
/// messages naming files pass through other code.
void check_flags(const CLI::App& cmd, const std::function<void()>& check);

} // namespace gshell::cli
