#pragma once
// The entry every benchmark shares, so that they all answer `--help` and bad input alike.

#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

namespace gshell::bench {

/// Runs `body` as a benchmark's main. `-h` or `--help` anywhere prints `usage` on stdout and
/// returns 0 before any argument is read (several benchmarks take their first argument as a model
/// path); an exception escaping `body` (a missing or unreadable model, a bad argument) is one line
/// on stderr naming the benchmark and returns 1, instead of std::terminate's abort.
inline int run_benchmark(int argc, char** argv, const char* usage, int (*body)(int, char**)) {
  std::string name = argc > 0 ? argv[0] : "bench";
  name = name.substr(name.find_last_of('/') + 1);
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "-h") || !std::strcmp(argv[i], "--help")) {
      std::fputs(usage, stdout);
      return 0;
    }
  try {
    return body(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
    return 1;
  }
}

} // namespace gshell::bench
