#pragma once
// Ctrl-C (SIGINT), SIGTERM, SIGHUP and SIGQUIT, the same for every command: the process removes the outputs it is
// still writing (gshell/io/temporary_outputs.h), prints "gshell: interrupted" and ends at once
// with status 128 + the signal's number. Without this, an interrupted `gshell deform -o OUT` left
// its half-written hidden folder beside OUT; now an interrupted command leaves nothing, as a
// failed one does not. A command can take the first signal itself (`gshell view` stops its server
// and exits normally); a second one ends the process as above.
#include <functional>

namespace gshell::cli {

/// Installs the handlers; main calls it once. From then on a library calling signal() cannot
/// replace them (METIS did, for SIGTERM, while CHOLMOD ordered a factor; interrupts.cpp says how).
/// A SIGINT or SIGHUP that was ignored when the process started (a background job of a
/// non-interactive shell, nohup) stays ignored. SIGXFSZ is ignored: a write past `ulimit -f` then
/// fails as any failed write does.
void catch_interrupts();

/// Never returns once a signal is ending the process: main calls it before it reports an error,
/// which may be only a consequence of the removal (a frame written into a removed folder), so
/// that the one line printed is "gshell: interrupted" and the status 128 + the signal.
void wait_if_interrupted();

/// The next signal calls `stop` (on the signal thread, while this function cannot return) instead
/// of ending the process; later signals end it. Empty `stop`: back to ending it. Once this returns,
/// an earlier `stop` is no longer running and will not be called.
void on_next_interrupt(std::function<void()> stop);

} // namespace gshell::cli
