// After a small sparse factorisation the process must go quiet: OpenBLAS's worker threads, once a
// threaded BLAS call wakes them, busy-wait for about 0.1 s, so a factorisation that woke them for
// a few milliseconds of work would leave a core spinning through the solve that follows
// (docs/design.md, "Speed"). Small factorisations therefore keep them asleep.
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include "shell_fixtures.h"

#include <gtest/gtest.h>

#include <chrono>
#include <ctime>
#include <dlfcn.h>
#include <numeric>
#include <thread>

namespace gshell {
namespace {

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

int openblas_threads() {
  using Get = int (*)();
  const auto get = reinterpret_cast<Get>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  return get ? get() : 0;
}

TEST(BlasThreads, ASmallFactorisationLeavesNoBlasThreadSpinning) {
  const int threads = openblas_threads();
  if (threads < 2) GTEST_SKIP() << "the BLAS in use is not a threaded OpenBLAS (threads: " << threads << ")";
  // OpenBLAS starts its workers spinning when it loads: let that first spin run out.
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  // A 20K-vertex shell: its factorisation calls BLAS with blocks large enough for OpenBLAS to
  // use its threads, yet takes some 5e7 flops (tens of milliseconds).
  const Shell shell = test::sphere_shell(4, 0.05);
  const int n = static_cast<int>(shell.base.rows());
  Eigen::MatrixXd X(2 * n, 3);
  X << shell.base, shell.top;
  const std::vector<int> fixed = test::vertex_range(0, n);
  const ShellSolver solver(rest_tets_from_positions(X, build_prism_tets(shell.F, n)), 2 * n, fixed);
  EXPECT_EQ(openblas_threads(), threads) << "the BLAS thread count is restored";

  // TBB's workers stop spinning within microseconds; give them 20 ms, then watch 150 ms of idling.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const double cpu_before = process_cpu_seconds();
  const auto wall_before = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  const double idle = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_before).count();
  const double cpu = process_cpu_seconds() - cpu_before;
  // A spinning worker would use about as much CPU as the idle wall time it overlaps (~0.08 s).
  EXPECT_LT(cpu, 0.25 * idle) << "CPU seconds used while idle after the factorisation: " << cpu << " of " << idle;
}

} // namespace
} // namespace gshell
