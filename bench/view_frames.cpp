// bench_view_frames: what `gshell view` of a deform output costs before the page opens and per
// frame shown when the sequence is too large to hold (ViewInputOptions::held_frame_bytes): the
// load (the first frame read, the others named) and read_view_frame of every other frame, in
// order, as the page playing the sequence asks for them.
//
//   bench_view_frames DEFORM_DIR [--runs R]
//
// DEFORM_DIR: a `gshell deform` output (frame_NNNN/ folders). Prints per run the load time and
// the median frame read, then the medians over the runs, with the shell's size.
#include "bench_main.h"
#include "bench_common.h"

#include <gshell/run/process_memory.h>
#include <gshell/view/view_input.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

using namespace gshell;
using bench::median;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

} // namespace

constexpr const char* kUsage = "usage: bench_view_frames DEFORM_DIR [--runs R]\n";

int bench_main(int argc, char** argv) {
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 1;
  }
  const std::string dir = argv[1];
  int runs = 3;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) runs = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "bench_view_frames: unknown argument %s\n", a.c_str());
      return 1;
    }
  }
  gshell::reuse_freed_memory(); // as the gshell CLI does
  ViewInputOptions options;
  options.held_frame_bytes = 1; // every frame but the first read when shown
  std::vector<double> load_runs, read_runs;
  for (int r = 0; r < runs; ++r) {
    const auto load_start = Clock::now();
    const ViewInput input = load_view_input({dir}, options);
    const double load_ms = ms_since(load_start);
    if (input.frames.size() < 2) throw std::runtime_error(dir + ": not a sequence of frames");
    std::vector<double> reads;
    for (int k = 1; k < static_cast<int>(input.frames.size()); ++k) {
      const auto start = Clock::now();
      const ViewFrame frame = read_view_frame(input, k);
      reads.push_back(ms_since(start));
      if (frame.X.rows() != 2 * input.shell.base.rows()) throw std::runtime_error(frame.name + ": wrong vertex count");
    }
    if (r == 0)
      std::printf("%s: %zu frames of %ld shell vertices, %ld faces\n", dir.c_str(), input.frames.size(),
                  static_cast<long>(2 * input.shell.base.rows()), static_cast<long>(input.shell.F.rows()));
    std::printf("  run %d: load %.0f ms, frame read median %.0f ms (min %.0f, max %.0f)\n", r + 1, load_ms, median(reads),
                *std::min_element(reads.begin(), reads.end()), *std::max_element(reads.begin(), reads.end()));
    load_runs.push_back(load_ms);
    read_runs.push_back(median(reads));
  }
  std::printf("median of %d runs: load %.0f ms, frame read %.0f ms\n", runs, median(load_runs), median(read_runs));
  return 0;
}

int main(int argc, char** argv) {
  gshell::restart_with_huge_pages(argv); // as the gshell CLI does
  return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main);
}
