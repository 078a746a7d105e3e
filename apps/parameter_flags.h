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

/// Throws InputError "FLAG applies only to WHEN" when `flag` (a long flag of `cmd`) was given
/// although `applies` is false: an option a run would ignore is a mistake to be told of.
void check_applies(const CLI::App& cmd, const std::string& flag, bool applies, const std::string& when);

} // namespace gshell::cli
