#pragma once
// The logic of `gshell view` without a network: what a page's messages do to the shell and what
// goes back to the pages. A ViewServer (view/view_server.h) owns one and calls it from its solver
// thread; tests drive it directly.
//
// A posable input is a DragSession (run/drag_session.h): handle groups, drag events solved from
// drag-extrapolated starts with a small per-event budget, a settle to convergence when the mouse
// rests (interruptible by the next event), undo/reset, the handle file and the pose folder. A
// sequence (a deform output, several shell folders) only shows frames.
//
// Drags coalesce: receive() only records a drag's target; solve_drag() solves once for all drags
// received since the last solve, so while a solve runs only the latest target of each group counts.
//
// Everything that goes to the pages passes through a ViewSink: JSON text messages (docs/viewer.md)
// and binary frames (view/view_protocol.h). Not thread-safe: one caller at a time.
#include <gshell/run/drag_session.h>
#include <gshell/run/pose_run.h>
#include <gshell/view/view_input.h>
#include <gshell/view/view_protocol.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace gshell {

/// One message to the pages.
struct ViewOutgoing {
  std::string bytes;
  bool binary = false;
  /// Only for the page whose message caused it (errors, the handle file); else for every page.
  bool to_sender = false;
  /// A snapshot of the session's state (the stats message): a newer one makes a waiting one
  /// obsolete, so a page that is slow to draw is not sent a backlog of them.
  bool snapshot = false;
};
using ViewSink = std::function<void(ViewOutgoing)>;

struct ViewSessionOptions {
  /// Solver kind, hierarchy, and the settle's limits (the pose job's defaults, PoseOptions{}),
  /// except that drag events are unguarded previews (their validity shown by the check thread)
  /// and the settle makes the resting state valid: a guarded step per event costs a certificate
  /// of the whole shell, far beyond a frame's budget on big meshes.
  PoseOptions pose = [] {
    PoseOptions p;
    p.guard_drag_steps = false;
    return p;
  }();
  /// How a drag event is answered (the settle finishes the job when the mouse rests):
  /// true: the hierarchical solver's finest reduced level moves the shell from where the drag
  /// began (DragSession::preview: no full-level work, a few milliseconds on bunny00);
  /// false, or the single-level solver: outer iterations of the full solver from the
  /// drag-extrapolated start (DragSession::drag), as `gshell pose --steps` takes its steps.
  bool reduced_events = true;
  /// Iterations per drag event, of the reduced level from its drag-extrapolated start
  /// (reduced_events; bunny00: more iterations hardly lower the preview's energy) or of the full
  /// solver (1: one Anderson-accelerated local/global iteration).
  int event_iterations = 1;
  /// Colors and stretch statistics are recomputed with every event when they cost at most this
  /// fraction of the event's solve, else only while settling and at rest (big meshes).
  double values_share = 0.25;
  /// Where save_shell writes its folders (must exist; a page names only a new folder in it).
  std::string output_dir = ".";
  /// Sizes and shapes a page message may have (vertex_count is set from the shell).
  ViewMessageLimits limits;

  /// \throws InputError naming the parameter (event_iterations, values_share, output_dir, or the
  ///         pose options') when it is out of range.
  void check() const;
};

class ViewSession {
public:
  using Clock = std::chrono::steady_clock;

  /// \throws InputError on bad options or an input without a positive thickness.
  ViewSession(ViewInput input, ViewSessionOptions options = {});
  ~ViewSession();
  ViewSession(ViewSession&&) noexcept;
  ViewSession& operator=(ViewSession&&) noexcept;

  /// Where lines for the terminal go (what was saved, where).
  void set_log(std::function<void(const std::string&)> log);

  const ViewInput& input() const;
  const ViewMessageLimits& limits() const;
  /// Null for a sequence.
  const DragSession* drag_session() const;

  /// Everything a page needs when it connects: hello, the faces, the current positions and
  /// colors, the handle groups and the statistics.
  void welcome(const ViewSink& send);

  /// A page went away (a closed tab, a reload). It may have gone mid-drag, without the release
  /// that tells the other pages where the drag left the groups: they are told now (the settle
  /// follows when no drag comes for the rest time, as after any drag).
  void page_left(const ViewSink& send);

  /// One message from a page: parsed (parse_view_message) and applied. A bad message, or one the
  /// session cannot carry out (an unknown group, handles leaving a part of the shell free, a
  /// folder that exists...), gets an "error" message to the sender and changes nothing.
  void receive(std::string_view bytes, const ViewSink& send, Clock::time_point received = Clock::now());
  /// The same for a parsed message. \throws InputError when it cannot be carried out.
  void apply(const ViewMessage& message, const ViewSink& send, Clock::time_point received = Clock::now());
  /// Loads handle groups (e.g. `--handles`), as the page's load_handles does; motions are solved
  /// by the next solve_drag() and settle(). \throws InputError naming `name` on a bad file.
  void load_handles(const std::string& text, const std::string& name, const ViewSink& send);

  /// Drag targets (or loaded motions) wait for solve_drag().
  bool drag_pending() const;
  /// Solves one event for the latest targets (event_iterations) and sends the positions, and the
  /// colors and statistics when they are cheap enough (values_share).
  /// \throws InputError when the handles leave a part of the shell free (nothing changes).
  void solve_drag(const ViewSink& send);

  /// The shell has moved since the last converged settle (or a drag was released).
  bool settle_pending() const;
  /// A release asked for an immediate settle.
  bool settle_requested() const;
  /// Runs the solver on to convergence with the session's tolerance, asking `interrupt` after
  /// every iteration; sends positions every `stream_seconds` while it runs, and the positions,
  /// colors and statistics at the end. Returns true when converged, false when interrupted.
  /// \throws InputError as solve_drag().
  bool settle(const ViewSink& send, const std::function<bool()>& interrupt, double stream_seconds = 0.25);

  /// The validity figures (inverted tets, intersections, valid) of a snapshot of the shell,
  /// computed off the interactive path (ViewServer: on a low-priority thread).
  struct CertifyTask {
    std::uint64_t version = 0; ///< of the shell state it was taken from
    Eigen::MatrixXd X;         ///< 2n x 3
    Eigen::MatrixXi F;
  };
  /// A task when the current shell has not been measured yet.
  std::optional<CertifyTask> certify_task() const;
  /// Runs a task (any thread): the "validity" object of the statistics.
  static nlohmann::ordered_json run_certify_task(const CertifyTask& task);
  /// Takes a task's result; sends the statistics when it is still about the current shell
  /// (else drops it: the shell moved meanwhile). Returns whether it was current.
  bool certified(std::uint64_t version, nlohmann::ordered_json validity, const ViewSink& send);
  /// All three at once, on this thread (tests, the page's "certify" message).
  void certify(const ViewSink& send);

  /// Builds the solver for new handle groups ahead of the first drag. Errors (e.g. a part of the
  /// shell without a handle, fine while the user is still adding groups) are kept for the
  /// statistics, not thrown. Returns true when it did work.
  bool prepare();

  /// The statistics message as sent (docs/viewer.md): sizes, last step, stretch, validity.
  nlohmann::ordered_json stats() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell
