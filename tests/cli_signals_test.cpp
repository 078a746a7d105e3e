// The CLI's signal handlers (apps/interrupts.cpp) stay installed whatever a library asks: METIS,
// which CHOLMOD calls to order large factors, replaced SIGTERM's while it ran and swallowed the
// signal. Built with the CLI's interrupts.cpp and its link option (CMakeLists.txt).
#include "interrupts.h"

#include <gtest/gtest.h>

#include <atomic>
#include <csignal>
#include <dlfcn.h>
#include <string>

namespace {

using SignalFunction = __sighandler_t (*)(int, __sighandler_t);

std::atomic<int> g_usr1{0};
extern "C" void count_usr1(int) { ++g_usr1; }

__sighandler_t current_handler(int signal) {
  struct sigaction action {};
  sigaction(signal, nullptr, &action);
  return action.sa_handler;
}

} // namespace

TEST(CliSignals, ALibraryCannotReplaceTheInterruptHandlersButSetsOthers) {
  gshell::cli::catch_interrupts();
  const __sighandler_t installed = current_handler(SIGTERM);
  ASSERT_NE(installed, SIG_DFL);
  void* const libc = dlopen("libc.so.6", RTLD_NOW | RTLD_NOLOAD);
  ASSERT_NE(libc, nullptr);
  // The function a library binds to is the first definition in the global scope. libmetis, built
  // as strict C, calls __sysv_signal; C++ and GNU C code signal.
  for (const char* name : {"signal", "__sysv_signal"}) {
    SCOPED_TRACE(name);
    const auto library_signal = reinterpret_cast<SignalFunction>(dlsym(RTLD_DEFAULT, name));
    ASSERT_NE(library_signal, nullptr);
    EXPECT_NE(reinterpret_cast<void*>(library_signal), dlsym(libc, name)) << "libc's is the one libraries call";
    // GKlib's trap and untrap: the handler it is told of is the one it gives back, and it stays.
    for (const int signal : {SIGTERM, SIGINT, SIGQUIT}) {
      const __sighandler_t told = library_signal(signal, SIG_DFL);
      EXPECT_EQ(current_handler(signal), installed) << signal;
      library_signal(signal, told);
      EXPECT_EQ(current_handler(signal), installed) << signal;
    }
    // Any other signal is set as libc sets it, and delivered to the new handler.
    g_usr1 = 0;
    EXPECT_EQ(library_signal(SIGUSR1, count_usr1), SIG_DFL);
    EXPECT_EQ(current_handler(SIGUSR1), count_usr1);
    std::raise(SIGUSR1);
    EXPECT_EQ(g_usr1, 1);
    EXPECT_EQ(library_signal(SIGUSR1, SIG_DFL), std::string(name) == "signal" ? count_usr1 : SIG_DFL)
        << "System V's handler is reset to the default by its first delivery";
    EXPECT_EQ(library_signal(-1, SIG_DFL), SIG_ERR);
  }
  dlclose(libc);
}
