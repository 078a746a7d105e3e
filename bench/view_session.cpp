// bench_view_session: what one drag event of `gshell view` costs on the solver thread, without a
// network or a browser (bench/view.mjs measures those): the scripted drag of bench/view.mjs (N
// events along a straight line, then the settle) applied to a ViewSession directly, so the time
// from a drag message in to its positions frame out is split into its parts. Being one thread and
// no I/O it also runs under `valgrind --tool=callgrind` for a load-independent count.
//
//   bench_view_session SHELL_DIR [--bowl] [--events N] [--runs R] [--event-iterations K] [--full-events] [--energy] [--no-settle]
//
// SHELL_DIR: a shell folder (bench/view.mjs makes out/bench-view/bunny: bunny00 at ratio 0.01).
// Handles: bench_pose's pull (bench_common.h pull_handles; --bowl for the bowl's).
// Per run and event: message in -> positions frame handed to the sink (what the server's frame
// header reports), of which DragSession::drag (prediction + solve) and the positions encoding;
// the settle's iterations, time and energy; then medians over the runs.
#include "bench_main.h"
#include "bench_common.h"

#include <gshell/quality/stretch.h>
#include <gshell/run/drag_session.h>
#include <gshell/view/view_input.h>
#include <gshell/view/view_session.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <sys/resource.h>
#include <string>
#include <vector>

using namespace gshell;
using bench::median;
using Clock = std::chrono::steady_clock;

namespace {

// CPU milliseconds of the process so far, all threads: what other load on a shared machine hardly changes.
double cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1e3 * (u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-3 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

std::string ids_json(const std::vector<int>& ids) {
  std::string s = "[";
  for (std::size_t k = 0; k < ids.size(); ++k) s += (k ? "," : "") + std::to_string(ids[k]);
  return s + "]";
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_view_session SHELL_DIR [--bowl] [--events N] [--runs R] [--event-iterations K] [--full-events] [--energy] [--no-settle]\n";

int bench_main(int argc, char** argv) {
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 1;
  }
  const std::string dir = argv[1];
  bool bowl = false, settle = true, energy = false;
  int events = 60, runs = 3;
  ViewSessionOptions options;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--bowl") bowl = true;
    else if (a == "--no-settle") settle = false;
    else if (a == "--full-events") options.reduced_events = false;
    else if (a == "--energy") energy = true;
    else if (a == "--events" && i + 1 < argc) events = std::atoi(argv[++i]);
    else if (a == "--runs" && i + 1 < argc) runs = std::atoi(argv[++i]);
    else if (a == "--event-iterations" && i + 1 < argc) options.event_iterations = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "bench_view_session: unknown argument %s\n", a.c_str());
      return 1;
    }
  }
  ViewInput input = load_view_input({dir});
  const HandleSet pull = bench::pull_handles(input.shell, bowl);
  std::printf("bench_view_session: %s: %d shell vertices, %d tets; hold %zu, pull %zu vertices; %d events, %d runs, "
              "%d iterations per event\n",
              dir.c_str(), 2 * input.shell.num_base_vertices(), 3 * static_cast<int>(input.shell.F.rows()),
              pull.handles[0].vertices.size(), pull.handles[1].vertices.size(), events, runs, options.event_iterations);
  ViewSession session(std::move(input), options);
  // The sink: what the server would send; positions frames are timed as they are handed over.
  Clock::time_point handed{};
  std::size_t position_bytes = 0;
  const ViewSink sink = [&](ViewOutgoing out) {
    std::uint32_t kind = 0;
    if (out.binary && out.bytes.size() >= 4) std::memcpy(&kind, out.bytes.data(), 4);
    if (out.binary && kind == static_cast<std::uint32_t>(ViewFrameKind::Positions)) {
      handed = Clock::now();
      position_bytes = out.bytes.size();
    }
  };
  session.receive(R"({"type":"add_handle","name":"hold","vertices":)" + ids_json(pull.handles[0].vertices) + "}", sink);
  session.receive(R"({"type":"add_handle","name":"pull","vertices":)" + ids_json(pull.handles[1].vertices) + "}", sink);
  session.prepare();
  const Eigen::Vector3d move = pull.handles[1].translate;
  if (std::getenv("GSHELL_BENCH_MARK")) { // for `perf report --time`: when the events begin (CLOCK_MONOTONIC)
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    std::printf("events begin at %ld.%06ld\n", static_cast<long>(now.tv_sec), now.tv_nsec / 1000);
  }

  std::vector<double> cpu_runs, in_out_runs, drag_runs, settle_ms_runs, settle_it_runs;
  for (int r = 0; r < runs; ++r) {
    session.receive(R"({"type":"reset"})", sink);
    session.receive(R"({"type":"grab","handle":1})", sink);
    std::vector<double> in_out, drag_ms, event_energy, cpu;
    for (int k = 1; k <= events; ++k) {
      const Eigen::Vector3d t = move * k / events;
      char msg[256];
      std::snprintf(msg, sizeof msg, R"({"type":"drag","seq":%d,"handle":1,"translate":[%.17g,%.17g,%.17g]})", k, t.x(),
                    t.y(), t.z());
      const double cpu0 = cpu_ms();
      const auto in = Clock::now();
      session.receive(msg, sink, in);
      session.solve_drag(sink);
      cpu.push_back(cpu_ms() - cpu0);
      in_out.push_back(std::chrono::duration<double, std::milli>(handed - in).count());
      drag_ms.push_back(session.stats()["step"]["seconds"].get<double>() * 1000);
      if (energy) { // the pose energy sum_t vol_t ||F_t - R_t||^2 = sum_t vol_t stretch_t (hard handles)
        const DragSession& d = *session.drag_session();
        event_energy.push_back(d.rest_tets().volume.dot(tet_stretch(d.rest_tets(), d.vertices())));
      }
    }
    if (energy)
      std::printf("  run %d: event energies: first %.6g, median %.6g, last %.6g\n", r + 1, event_energy.front(),
                  median(event_energy), event_energy.back());
    std::printf("  run %d: median process CPU per event %.1f ms\n", r + 1, median(cpu));
    cpu_runs.push_back(median(cpu));
    if (!settle) {
      std::printf("  run %d: medians: message in -> positions out %.1f ms (solve %.1f ms)\n", r + 1, median(in_out),
                  median(drag_ms));
      in_out_runs.push_back(median(in_out));
      drag_runs.push_back(median(drag_ms));
      continue;
    }
    session.receive(R"({"type":"release"})", sink);
    const auto settle_start = Clock::now();
    session.settle(sink, [] { return false; });
    const double settle_ms = ms_since(settle_start);
    const nlohmann::ordered_json step = session.stats()["step"];
    std::printf("  run %d: medians: message in -> positions out %.1f ms (solve %.1f ms); settle %d iterations, %.0f ms, "
                "energy %.10g (%s); positions frame %zu bytes\n",
                r + 1, median(in_out), median(drag_ms), step["iterations"].get<int>(), settle_ms,
                step["energy"].get<double>(), step["converged"].get<bool>() ? "converged" : "not converged",
                position_bytes);
    in_out_runs.push_back(median(in_out));
    drag_runs.push_back(median(drag_ms));
    settle_ms_runs.push_back(settle_ms);
    settle_it_runs.push_back(step["iterations"].get<int>());
  }
  std::printf("median of %d runs: message in -> positions out %.1f ms (goal bunny00 <= 33 ms, bowl <= 8 ms), solve %.1f ms, "
              "process CPU per event %.1f ms; settle %.0f iterations, %.0f ms\n",
              runs, median(in_out_runs), median(drag_runs), median(cpu_runs), median(settle_it_runs), median(settle_ms_runs));
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
