#include "interrupts.h"

#include <gshell/io/temporary_outputs.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <unistd.h>

namespace gshell::cli {

namespace {

// The handler only writes the signal's number into a pipe (async-signal-safe, whichever thread
// it interrupts: libraries start threads of their own); a waiting thread does the rest.
int g_pipe[2] = {-1, -1};
std::mutex g_mutex;
std::function<void()> g_stop;
std::atomic<bool> g_ending{false};

extern "C" void on_signal(int signal) {
  const unsigned char byte = static_cast<unsigned char>(signal);
  [[maybe_unused]] const ssize_t written = ::write(g_pipe[1], &byte, 1);
}

[[noreturn]] void end_process(int signal) {
  g_ending = true;
  // Other threads go on printing (a frame's line, a warning) until the process ends: their stderr
  // is pointed at /dev/null first, so "gshell: interrupted" stays the last line.
  int err = ::dup(2);
  if (err < 0) err = 2;
  if (const int null = ::open("/dev/null", O_WRONLY); null >= 0) ::dup2(null, 2);
  remove_temporary_outputs(/*for_exit=*/true); // a writer still running now blocks at its next file
  // After "^C" on a terminal, or an open status line there, the message needs a line of its own.
  const char* line = ::isatty(err) ? "\ngshell: interrupted\n" : "gshell: interrupted\n";
  [[maybe_unused]] const ssize_t written = ::write(err, line, std::strlen(line));
  std::_Exit(128 + signal);
}

void watch_signals() {
  for (;;) {
    unsigned char signal = 0;
    if (::read(g_pipe[0], &signal, 1) != 1) continue;
    const std::lock_guard lock(g_mutex);
    if (!g_stop) end_process(signal);
    const std::function<void()> stop = std::move(g_stop);
    g_stop = nullptr;
    stop();
  }
}

// The signals whose handler catch_interrupts installed (the others are the libraries' to set).
std::atomic<bool> g_kept[NSIG];

bool ignored_at_start(int signal) {
  struct sigaction current {};
  return sigaction(signal, nullptr, &current) == 0 && current.sa_handler == SIG_IGN;
}

} // namespace

void catch_interrupts() {
  if (::pipe(g_pipe) != 0) throw std::runtime_error("cannot create a pipe for signals");
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  // SIGHUP (the terminal closed, an ssh session dropped) and SIGQUIT (Ctrl-\\) end a run as Ctrl-C
  // does: by default they killed it and left its hidden staging folder behind. SIGINT and SIGHUP
  // ignored at the start (a background job, nohup) stay ignored.
  for (const int signal : {SIGINT, SIGHUP})
    if (!ignored_at_start(signal) && sigaction(signal, &action, nullptr) == 0) g_kept[signal] = true;
  for (const int signal : {SIGTERM, SIGQUIT})
    if (sigaction(signal, &action, nullptr) == 0) g_kept[signal] = true;
  // Past a file size limit (ulimit -f) a write should fail, and the command report it and remove
  // what it was writing, instead of the process being killed in the middle of it.
  std::signal(SIGXFSZ, SIG_IGN);
  std::thread(watch_signals).detach();
}

void wait_if_interrupted() {
  if (!g_ending) return;
  for (;;) ::pause(); // the signal thread ends the process
}

void on_next_interrupt(std::function<void()> stop) {
  const std::lock_guard lock(g_mutex);
  g_stop = std::move(stop);
}

} // namespace gshell::cli

// METIS, which CHOLMOD calls to order large factors (pose and the viewer's drags), installs a
// handler of its own for SIGTERM while it runs (GKlib's gk_sigtrap, through signal(), which its C
// build binds to __sysv_signal) that longjmps out of METIS: a SIGTERM then was swallowed (the run
// went on, wrote its output and exited 0), and taken on another thread it crashed the process.
// The executable's definitions are found before libc's by every library (they are exported:
// --export-dynamic-symbol in CMakeLists.txt), so a library can no longer replace the handlers
// above; any other request is done as libc does it.
namespace {

__sighandler_t set_handler(int signal, __sighandler_t handler, bool system_v) noexcept {
  if (signal > 0 && signal < NSIG && gshell::cli::g_kept[signal]) return gshell::cli::on_signal;
  struct sigaction action {}, before {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  if (system_v) {
    action.sa_flags = SA_RESETHAND | SA_NODEFER; // one delivery, then the default
  } else {
    if (signal > 0 && signal < NSIG) sigaddset(&action.sa_mask, signal); // BSD: blocked in its handler
    action.sa_flags = SA_RESTART;
  }
  if (sigaction(signal, &action, &before) != 0) return SIG_ERR;
  return before.sa_handler;
}

} // namespace

extern "C" __sighandler_t signal(int signal, __sighandler_t handler) noexcept {
  return set_handler(signal, handler, false);
}

extern "C" __sighandler_t __sysv_signal(int signal, __sighandler_t handler) noexcept {
  return set_handler(signal, handler, true);
}
