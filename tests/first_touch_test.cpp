// Buffers faulted in from all threads (src/geometry/first_touch.h, internal to the library): the
// pages are backed without changing what they hold, and assign_populated is std::vector's assign.
// The sizes are above the threshold from which the pages are populated by madvise.
#include "geometry/first_touch.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace {

constexpr std::size_t kLarge = std::size_t{5} << 20; // doubles: 40 MB

TEST(FirstTouch, PopulatingKeepsTheContents) {
  std::vector<double> v(kLarge);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = 0.5 * static_cast<double>(i);
  // Misaligned on both ends, so the pages it shares with its neighbours are left alone.
  gshell::detail::populate_in_parallel(reinterpret_cast<char*>(v.data()) + 3, v.size() * sizeof(double) - 7);
  for (std::size_t i = 0; i < v.size(); ++i) ASSERT_EQ(v[i], 0.5 * static_cast<double>(i)) << "entry " << i;
  gshell::detail::populate_in_parallel(nullptr, kLarge); // nothing to do
}

TEST(FirstTouch, AssignPopulatedIsAssign) {
  for (std::size_t n : {std::size_t{0}, std::size_t{10}, kLarge, kLarge / 2}) {
    std::vector<std::int32_t> v(7, 9); // an old content of another size, dropped
    gshell::detail::assign_populated(v, n, std::int32_t{-1});
    ASSERT_EQ(v.size(), n);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(v[i], -1) << "entry " << i << " of " << n;
    std::vector<double> w;
    gshell::detail::assign_populated(w, n);
    ASSERT_EQ(w.size(), n);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(w[i], 0.0) << "entry " << i << " of " << n;
  }
}

} // namespace
