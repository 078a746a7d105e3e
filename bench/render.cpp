// Times a 1280x720 render of a shell folder (default: the bunny00 shell, generated with
// `gshell generate models/bunny00.off -o DIR --thickness-ratio 0.03` into a temp folder if no DIR
// is given), phase by phase: load, render (OSMesa), PNG encoding, and the end-to-end CLI.
// Usage: bench_render [SHELL_DIR] [RUNS]; prints medians (wall clock; the machine may be shared).
#include "bench_main.h"
#include <gshell/render/image.h>
#include <gshell/render/shell_render.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

namespace {

// CPU seconds of this process (all threads, incl. llvmpipe's) plus its waited-for children: on a
// shared machine the wall clock also counts time spent waiting for a core.
double cpu_seconds() {
  rusage self{}, children{};
  getrusage(RUSAGE_SELF, &self);
  getrusage(RUSAGE_CHILDREN, &children);
  auto sec = [](const timeval& t) { return t.tv_sec + 1e-6 * t.tv_usec; };
  return sec(self.ru_utime) + sec(self.ru_stime) + sec(children.ru_utime) + sec(children.ru_stime);
}

struct Timing {
  double wall = 0, cpu = 0; ///< medians, seconds
};

template <class F>
Timing median_seconds(int runs, F&& f) {
  std::vector<double> wall, cpu;
  for (int i = 0; i < runs; ++i) {
    const double cpu_start = cpu_seconds();
    const auto start = std::chrono::steady_clock::now();
    f();
    wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    cpu.push_back(cpu_seconds() - cpu_start);
  }
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  return {wall[wall.size() / 2], cpu[cpu.size() / 2]};
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_render [SHELL_DIR] [RUNS=5]\n"
    "(default: the bunny00 shell at ratio 0.03, generated into a temporary folder)\n";

int bench_main(int argc, char** argv) {
  namespace fs = std::filesystem;
  const int runs = argc > 2 ? std::atoi(argv[2]) : 5;
  const fs::path cli = fs::path(argv[0]).parent_path() / "gshell";
  std::string dir = argc > 1 ? argv[1] : "";
  const fs::path scratch = fs::temp_directory_path() / ("gshell-bench-render-" + std::to_string(::getpid()));
  if (dir.empty()) {
    if (!fs::exists("models/bunny00.off")) {
      std::fprintf(stderr, "bench_render: models/bunny00.off missing (run scripts/fetch-models) or pass a shell folder\n");
      return 1;
    }
    fs::create_directories(scratch);
    dir = (scratch / "bunny00").string();
    const std::string cmd = "'" + cli.string() + "' generate models/bunny00.off -o '" + dir + "' --thickness-ratio 0.03 -q >/dev/null";
    if (std::system(cmd.c_str()) != 0) return 1;
  }
  const std::string png = (scratch / "render.png").string();
  fs::create_directories(scratch);

  gshell::RenderSubject subject;
  const Timing load = median_seconds(runs, [&] { subject = gshell::load_render_subject(dir); });
  gshell::ShellRenderOptions options; // 1280x720, iso, 2x supersampling, stretch colors
  gshell::Image image;
  const Timing render = median_seconds(runs, [&] { image = gshell::render_subjects({subject}, {}, options); });
  std::string bytes;
  const Timing encode = median_seconds(runs, [&] { bytes = gshell::encode_png(image); });
  const std::string cmd = "'" + cli.string() + "' render '" + dir + "' -o '" + png + "' -q";
  const Timing end_to_end = median_seconds(runs, [&] {
    if (std::system(cmd.c_str()) != 0) std::exit(1);
  });
  std::printf("shell %s: %lld base vertices, %lld faces; image %dx%d, %zu PNG bytes\n", dir.c_str(),
              static_cast<long long>(subject.shell.base.rows()), static_cast<long long>(subject.shell.F.rows()), image.width,
              image.height, bytes.size());
  double load_average[3] = {0, 0, 0};
  getloadavg(load_average, 3);
  std::printf("median of %d runs (wall / CPU seconds; load average %.1f on %ld cores):\n", runs, load_average[0],
              sysconf(_SC_NPROCESSORS_ONLN));
  std::printf("  load shell folder  %.3f / %.3f\n", load.wall, load.cpu);
  std::printf("  render 1280x720    %.3f / %.3f\n", render.wall, render.cpu);
  std::printf("  PNG encode         %.3f / %.3f\n", encode.wall, encode.cpu);
  std::printf("  gshell render CLI  %.3f / %.3f  (end to end: start, load, render, encode, write)\n", end_to_end.wall,
              end_to_end.cpu);
  std::error_code ec;
  fs::remove_all(scratch, ec);
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
