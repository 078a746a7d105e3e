#include "progress.h"

#include "command_registry.h"

#include <cstdio>
#include <iostream>
#include <memory>
#include <unistd.h>

namespace gshell::cli {

Progress::Progress(const std::string& command, double min_interval)
    : prefix_("gshell " + command + ": "), enabled_(!global_options().quiet), terminal_(::isatty(STDERR_FILENO) == 1),
      min_interval_(min_interval) {}

Progress::~Progress() { finish_status(); }

void Progress::update(const std::string& text, bool always) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (!always && min_interval_ > 0 && last_ != std::chrono::steady_clock::time_point{} &&
      std::chrono::duration<double>(now - last_).count() < min_interval_)
    return;
  last_ = now;
  // Each line goes out in one write: std::cerr writes every insertion at once, and the interrupt
  // message (another thread's write) must not land between a line's prefix and its text.
  if (terminal_) {
    std::cerr << ("\r\033[K" + prefix_ + text) << std::flush; // \033[K clears the rest of the old line
    status_open_ = true;
  } else {
    std::cerr << (prefix_ + text + "\n");
  }
}

void Progress::terminal_status(const std::string& text) {
  if (terminal_) update(text, true);
}

void Progress::line(const std::string& text) {
  if (!enabled_) return;
  finish_status();
  std::cerr << (prefix_ + text + "\n");
}

void Progress::finish_status() {
  if (status_open_) std::cerr << "\r\033[K" << std::flush; // the status line gives way
  status_open_ = false;
}

void show_solve_progress(Progress& progress, SolveOptions& solve, const std::string& lead) {
  if (!progress.enabled()) return;
  auto stage = std::make_shared<std::string>();
  // Each stage shows when it begins: generation's phases without iterations (setup, factor, start,
  // metrics, certificate) take tens of seconds at millions of faces and would be silent.
  solve.stage = [&progress, stage, lead](const char* name) {
    *stage = std::string(name) + ": ";
    progress.update(lead + name + "...");
  };
  solve.progress = [&progress, stage, lead](int it, double energy, double seconds) {
    char text[96];
    std::snprintf(text, sizeof text, "iteration %d  energy %.6g  %.3f s", it, energy, seconds);
    progress.update(lead + *stage + text);
  };
}

} // namespace gshell::cli
