// How much the machine charges for memory a process touches for the first time: maps GB gigabytes
// one at a time, writes one byte per 4 KB page and prints the seconds each gigabyte took. On the
// project's 2-core virtual machine the first 2-3 GB cost about 0.4 s each and every further one
// about 3.2 s (the host backs guest memory lazily and takes freed memory back): that is what makes
// builtin:sphere:9 (a 6.7 GB peak) grow faster than sphere:8 (1.7 GB) in bench_scale
// (docs/scale.md). On an ordinary machine every gigabyte costs the same, well under 0.5 s.
//   bench_first_touch [GB]      (default 8)
#include "bench_main.h"
#include <sys/mman.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

constexpr const char* kUsage =
    "usage: bench_first_touch [GB=8]\n"
    "(seconds to touch each further gigabyte of fresh memory for the first time)\n";

int bench_main(int argc, char** argv) {
  const long gigabytes = argc > 1 ? std::atol(argv[1]) : 8;
  if (gigabytes <= 0) {
    std::fputs(kUsage, stderr);
    return 1;
  }
  constexpr std::size_t kGigabyte = std::size_t{1} << 30, kPage = 4096;
  std::printf("GB  seconds to touch it for the first time\n");
  for (long g = 0; g < gigabytes; ++g) {
    void* block = mmap(nullptr, kGigabyte, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (block == MAP_FAILED) {
      std::fprintf(stderr, "bench_first_touch: could not map gigabyte %ld\n", g + 1);
      return 1;
    }
    volatile char* bytes = static_cast<char*>(block);
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < kGigabyte; k += kPage) bytes[k] = 1;
    std::printf("%2ld  %.3f\n", g + 1, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    std::fflush(stdout);
  }
  return 0; // the mappings are the process's until it exits, as a generation's peak is
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
