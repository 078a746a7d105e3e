#pragma once
// Progress of long runs on stderr, the same for every command: on a terminal one status line
// rewritten in place; anywhere else (a log, a pipe) one line per update, so logs read cleanly.
// Nothing at all with --quiet.
#include <gshell/solver/shell_solver.h>

#include <chrono>
#include <string>
#include <string_view>

namespace gshell::cli {

class Progress {
public:
  /// Lines start with "gshell COMMAND: ". Status updates closer than `min_interval` seconds to the
  /// last shown one are dropped (permanent lines never are).
  explicit Progress(const std::string& command, double min_interval = 0);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  bool enabled() const { return enabled_; }
  /// A status line that the next update replaces (on a terminal). `always`: shown even within
  /// `min_interval` of the last (a phase that begins and then runs long without updates).
  void update(const std::string& text, bool always = false);
  /// A status line on a terminal only, for a phase before the first line a log should carry
  /// (reading the input): a log keeps one line for an input error, a terminal is not left silent.
  void terminal_status(const std::string& text);
  /// A line that stays.
  void line(const std::string& text);
  /// Clears an open status line (on a terminal), e.g. before printing to stdout.
  void finish_status();

private:

  std::string prefix_;
  bool enabled_ = false, terminal_ = false, status_open_ = false;
  double min_interval_ = 0;
  std::chrono::steady_clock::time_point last_{};
};

/// Whether a stage name is a setup ("guard setup", "regenerate setup"): such a stage runs long
/// without iterations or a later stage that could show it, so it is shown at once, past throttles.
inline bool is_setup_stage(std::string_view name) {
  return name.size() >= 5 && name.substr(name.size() - 5) == "setup";
}

/// Shows a (possibly staged) solve's iterations on `progress` as "LEAD[STAGE: ]iteration N  energy
/// E  T s", STAGE being what `solve.stage` last named (guarded generation: paper, repair, relax),
/// so that a counter starting again reads as the next stage, and each stage as "LEADSTAGE..." when
/// it begins (T is the time since the stage began). Nothing when progress is off.
/// `progress` must outlive the solve.
void show_solve_progress(Progress& progress, SolveOptions& solve, const std::string& lead = "");

} // namespace gshell::cli
