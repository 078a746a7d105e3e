// Anderson acceleration's history (src/solver/anderson_history.h, internal to the library): the
// passes over iterates of millions of values run in parallel blocks, and must give the serial
// passes' combination up to rounding, and the same bits from run to run.
#include "solver/anderson_history.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <vector>

namespace {

using gshell::detail::AndersonHistory;

// A linear contraction x -> a .* x + b, its rates spread over (0.2, 0.9).
struct LinearMap {
  Eigen::VectorXd a, b;
  explicit LinearMap(Eigen::Index size) : a(size), b(size) {
    for (Eigen::Index i = 0; i < size; ++i) {
      a(i) = 0.2 + 0.7 * static_cast<double>((i * 7919) % 1000) / 1000.0;
      b(i) = std::sin(0.001 * static_cast<double>(i));
    }
  }
  Eigen::VectorXd operator()(const Eigen::VectorXd& x) const { return a.cwiseProduct(x) + b; }
};

// Feeds the plain iterates x_k+1 = G(x_k) from 0 to a history and returns its combination at
// every step that has one: both histories of a comparison see the same pairs.
template <typename Stored>
std::vector<Eigen::VectorXd> combinations(const LinearMap& map, int iterations, Eigen::Index blocked_from) {
  AndersonHistory<Stored> history(5, blocked_from);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(map.a.size()), combined(map.a.size());
  std::vector<Eigen::VectorXd> out;
  for (int k = 0; k < iterations; ++k) {
    const Eigen::VectorXd image = map(x);
    if (history.extrapolate(x.data(), image.data(), x.size(), combined.data())) out.push_back(combined);
    x = image;
  }
  return out;
}

constexpr Eigen::Index kSize = Eigen::Index{3} << 19; // 1.5 M values: 24 blocks of 64 K
constexpr Eigen::Index kNever = Eigen::Index{1} << 40;

template <typename Stored> void blocked_matches_serial() {
  const LinearMap map(kSize);
  const auto serial = combinations<Stored>(map, 8, kNever), blocked = combinations<Stored>(map, 8, 1);
  ASSERT_EQ(blocked.size(), serial.size());
  ASSERT_EQ(serial.size(), 7u); // every step after the first
  // The combination solves small normal equations of the differences, which amplify the
  // rounding of their dot products (summed in another order by blocks).
  for (std::size_t k = 0; k < serial.size(); ++k)
    EXPECT_LE((blocked[k] - serial[k]).norm(), 1e-6 * serial[k].norm()) << "step " << k;
  // The same bits on a second run, whatever the threads' schedule.
  const auto again = combinations<Stored>(map, 8, 1);
  for (std::size_t k = 0; k < blocked.size(); ++k)
    EXPECT_EQ((again[k] - blocked[k]).cwiseAbs().maxCoeff(), 0.0) << "step " << k;
}

TEST(AndersonHistory, BlockedPassesGiveTheSerialCombinationWithFloatHistory) { blocked_matches_serial<float>(); }

TEST(AndersonHistory, BlockedPassesGiveTheSerialCombinationWithDoubleHistory) { blocked_matches_serial<double>(); }

} // namespace
