// The face tree's float covers far from the model's origin: they must hold every box exactly
// (no pair missed) and stay as tight as near the origin (survey-coordinate scans), and two
// trees searched together must measure them from one origin.
#include "quality/face_bvh.h"

#include "core_test_meshes.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

using namespace gshell;
using detail::FaceBvh;

namespace {

// Pairs of faces whose float covers meet, over one tree.
long meeting_pairs(const FaceBvh& tree) {
  std::atomic<long> count{0};
  tree.for_each_pair_of_meeting_float_boxes([&](int, int) { ++count; });
  return count.load();
}

Eigen::MatrixXd translated(const Eigen::MatrixXd& V, const Eigen::RowVector3d& by) {
  return V.rowwise() + by;
}

} // namespace

TEST(FaceBvh, CoversFarFromTheOriginAreAsTightAsNearIt) {
  // 1,280 faces of a unit sphere; placed where survey coordinates put scans (a float's step is
  // 0.25-0.5 there), covers measured from the model's own origin met most other faces' covers.
  const test::SimpleMesh sphere = test::icosphere(3);
  const long near = meeting_pairs(FaceBvh(sphere.V, sphere.F, FaceBvh::Use::float_pairs));
  ASSERT_GT(near, 1000);
  for (const Eigen::RowVector3d& offset : {Eigen::RowVector3d(5e5, 4e6, 120), Eigen::RowVector3d(-3e5, 2e5, -7e5),
                                           Eigen::RowVector3d(0, 0, 1e9)}) {
    SCOPED_TRACE(offset);
    const long far = meeting_pairs(FaceBvh(translated(sphere.V, offset), sphere.F, FaceBvh::Use::float_pairs));
    EXPECT_GE(far, near - near / 100); // the translated doubles round a little differently
    EXPECT_LE(far, near + near / 100);
  }
}

TEST(FaceBvh, CoversOfHugeAndTinyModelsAreAsTightAsAtUnitScale) {
  // Coordinates up to 1e50 are accepted, beyond the float range (3.4e38): covers measured in
  // model units were all clamped there and every pair of faces met. Tiny models fall below the
  // normal floats. The cover frame's power-of-two scale keeps them at unit size.
  const test::SimpleMesh sphere = test::icosphere(3);
  const FaceBvh unit(sphere.V, sphere.F, FaceBvh::Use::float_pairs);
  const long near = meeting_pairs(unit);
  const long all = static_cast<long>(sphere.F.rows()) * (sphere.F.rows() - 1) / 2;
  ASSERT_LT(near, all / 10);
  for (double scale : {1e39, 1e45, 1e49, 1e-35, 1e-40}) {
    SCOPED_TRACE(scale);
    const Eigen::MatrixXd V = sphere.V * scale;
    const FaceBvh tree(V, sphere.F, FaceBvh::Use::float_pairs);
    const long count = meeting_pairs(tree);
    EXPECT_GE(count, near - near / 100);
    EXPECT_LE(count, near + near / 100);
    // Distances through the scaled covers come back in model units.
    const FaceBvh distances(V, sphere.F, FaceBvh::Use::distances);
    const FaceBvh unit_distances(sphere.V, sphere.F, FaceBvh::Use::distances);
    const Eigen::Vector3d q(0.3, 1.4, -0.2);
    const double expected = unit_distances.squared_distance(q, 1e300) * scale * scale;
    EXPECT_NEAR(distances.squared_distance(q * scale, std::numeric_limits<double>::max()), expected, 1e-9 * expected);
  }
}

TEST(FaceBvh, ACoverHoldsItsBoxAtEveryOffset) {
  // A box touching a face's box only along a face of the box is met; one a little apart is not
  // (where the coordinates leave room for the gap), however far from zero, and where the
  // differences to the tree's origin overflow the cover is unbounded rather than wrong.
  for (double offset : {0.0, 1.0, 4e6, -3e9, 1e15, 1e300}) {
    SCOPED_TRACE(offset);
    const Eigen::Vector3d lo = Eigen::Vector3d::Constant(offset), hi = lo + Eigen::Vector3d(1, 2, 3);
    const FaceBvh tree(std::vector<Eigen::AlignedBox3d>{Eigen::AlignedBox3d(lo, hi)});
    Eigen::Vector3d touch_lo = lo, touch_hi = hi;
    touch_lo.x() = hi.x();
    touch_hi.x() = hi.x() + 1;
    EXPECT_TRUE(tree.some_face_box_meets(Eigen::AlignedBox3d(touch_lo, touch_hi)));
    const double gap = 1e-3 + 1e-12 * std::abs(offset);
    if (hi.x() + gap > hi.x()) {
      touch_lo.x() = hi.x() + gap;
      touch_hi.x() = hi.x() + 2 * gap + 1;
      if (std::abs(offset) < 1e20) EXPECT_FALSE(tree.some_face_box_meets(Eigen::AlignedBox3d(touch_lo, touch_hi)));
    }
  }
  // A tree measured from an origin far from its boxes (differences that overflow).
  const Eigen::Vector3d lo = Eigen::Vector3d::Constant(1.5e308), hi = Eigen::Vector3d::Constant(1.6e308);
  const FaceBvh tree(std::vector<Eigen::AlignedBox3d>{Eigen::AlignedBox3d(lo, hi)}, 4,
                     detail::CoverFrame{Eigen::Vector3d::Constant(-1.7e308), 1.0});
  EXPECT_TRUE(tree.some_face_box_meets(Eigen::AlignedBox3d(hi, hi)));
}

TEST(FaceBvh, TreesSearchedTogetherShareTheirOrigin) {
  const test::SimpleMesh sphere = test::icosphere(2);
  const Eigen::MatrixXd moved = translated(sphere.V, Eigen::RowVector3d(0.5, 0, 0));
  const FaceBvh a(sphere.V, sphere.F, FaceBvh::Use::float_pairs);
  const FaceBvh b(moved, sphere.F, FaceBvh::Use::float_pairs);
  ASSERT_NE(a.frame(), b.frame());
  EXPECT_THROW(a.for_each_pair_of_meeting_float_boxes(b, [](int, int) {}), std::logic_error);
  // Given a's frame, b is searched in it, and finds what the exact boxes find.
  const FaceBvh c(moved, sphere.F, FaceBvh::Use::pairs, a.frame());
  const FaceBvh a_exact(sphere.V, sphere.F, FaceBvh::Use::pairs);
  std::atomic<long> covers{0}, exact{0};
  a.for_each_pair_of_meeting_float_boxes(c, [&](int, int) { ++covers; });
  a_exact.for_each_overlapping_pair(c, [&](int, int) { ++exact; });
  EXPECT_GT(exact.load(), 0);
  EXPECT_GE(covers.load(), exact.load());
}
