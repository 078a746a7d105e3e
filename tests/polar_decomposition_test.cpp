// closest_rotation against Eigen's JacobiSVD: R = U diag(1, 1, det U V^T) V^T.
#include <gshell/solver/polar_decomposition.h>

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <random>

using namespace gshell;

namespace {

struct Reference {
  Eigen::Matrix3d R;
  Eigen::Vector3d sigma; // signed: the last one carries det F's sign
};

Reference reference(const Eigen::Matrix3d& F) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  Reference r;
  r.sigma = svd.singularValues();
  if ((U * V.transpose()).determinant() < 0) {
    U.col(2) *= -1;
    r.sigma[2] *= -1;
  }
  r.R = U * V.transpose();
  return r;
}

Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
}

Eigen::Matrix3d with_singular_values(std::mt19937& rng, double s1, double s2, double s3) {
  return random_rotation(rng) * Eigen::Vector3d(s1, s2, s3).asDiagonal() * random_rotation(rng);
}

void expect_rotation(const Eigen::Matrix3d& R) {
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12) << R;
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
}

// The polar rotation is unique iff sigma_2 + sigma_3 > 0 (signed); its condition is
// ~ |F| / (sigma_2 + sigma_3). Compare R where that is bounded, the attained optimum everywhere.
void check(const Eigen::Matrix3d& F, double tol = 1e-9) {
  const Eigen::Matrix3d R = closest_rotation(F);
  expect_rotation(R);
  const Reference ref = reference(F);
  const double scale = std::max(std::abs(ref.sigma[0]), 1e-300); // F.norm() would underflow at 1e-200
  const double optimum = ref.sigma.sum(); // max over rotations of tr(R^T F)
  EXPECT_NEAR((R.transpose() * F).trace(), optimum, 1e-12 * scale) << F;
  const double gap = (ref.sigma[1] + ref.sigma[2]) / scale;
  if (gap > 1e-5) EXPECT_LT((R - ref.R).cwiseAbs().maxCoeff(), tol / std::min(1.0, gap * 1e3)) << F;
}

} // namespace

TEST(PolarDecomposition, RotationsAreReturnedExactly) {
  std::mt19937 rng(1);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Matrix3d Q = random_rotation(rng);
    EXPECT_LT((closest_rotation(Q) - Q).cwiseAbs().maxCoeff(), 1e-13);
  }
  EXPECT_LT((closest_rotation(Eigen::Matrix3d::Identity()) - Eigen::Matrix3d::Identity()).norm(), 1e-15);
}

TEST(PolarDecomposition, RandomMatricesMatchSvd) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 20000; ++i) {
    Eigen::Matrix3d F;
    for (int k = 0; k < 9; ++k) F(k / 3, k % 3) = u(rng);
    check(F);
  }
}

TEST(PolarDecomposition, StretchedAndScaledMatchSvd) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.2, 3.0);
  for (int i = 0; i < 5000; ++i) check(with_singular_values(rng, u(rng), u(rng), u(rng)));
  for (double s : {1e-200, 1e-12, 1e-3, 1e3, 1e12, 1e200}) check(s * with_singular_values(rng, 2, 1, 0.5));
}

TEST(PolarDecomposition, InvertedMatricesGiveProperRotation) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.2, 3.0);
  for (int i = 0; i < 5000; ++i) {
    double s[3] = {u(rng), u(rng), u(rng)};
    std::sort(s, s + 3, std::greater<>());
    check(with_singular_values(rng, s[0], s[1], -s[2]));
  }
  // A reflection: det R must still be +1, flipping the axis of the smallest singular value.
  const Eigen::Matrix3d M = Eigen::Vector3d(3, 2, -1).asDiagonal();
  EXPECT_LT((closest_rotation(M) - Eigen::Matrix3d(Eigen::Vector3d(1, 1, 1).asDiagonal())).norm(), 1e-14);
  check(-Eigen::Matrix3d::Identity() * 2 + 0.01 * Eigen::Matrix3d::Random());
}

TEST(PolarDecomposition, NearSingularAndRankDeficient) {
  std::mt19937 rng(5);
  for (double tiny : {1e-4, 1e-8, 1e-12, 1e-16, 0.0}) {
    for (int i = 0; i < 200; ++i) {
      check(with_singular_values(rng, 1.0, 0.7, tiny));  // rank 2 (+tiny): still unique
      check(with_singular_values(rng, 1.0, 0.7, -tiny));
      check(with_singular_values(rng, 1.0, tiny, tiny)); // rank 1: optimum only
      check(with_singular_values(rng, 1.0, tiny, -tiny));
      check(with_singular_values(rng, 1.0, 1.0, tiny));  // repeated singular values
      check(with_singular_values(rng, 2.0, 1.0, -1.0));  // sigma_2 + sigma_3 = 0: not unique
    }
  }
  expect_rotation(closest_rotation(Eigen::Matrix3d::Zero()));
  const Eigen::Vector3d a(1, 2, 3), b(-1, 0.5, 2);
  check(a * b.transpose());
  check(Eigen::Matrix3d(Eigen::Vector3d(1, 0, 0).asDiagonal()));
}

TEST(PolarDecomposition, NearRotationsTypicalOfShells) {
  std::mt19937 rng(6);
  std::normal_distribution<double> g(0, 0.2);
  for (int i = 0; i < 20000; ++i) {
    Eigen::Matrix3d P;
    for (int k = 0; k < 9; ++k) P(k / 3, k % 3) = g(rng);
    check(random_rotation(rng) * (Eigen::Matrix3d::Identity() + P), 1e-10);
  }
}

TEST(PolarDecomposition, BatchedLanesAgreeWithSingleCalls) {
  // Mixed batch: lanes that take the Newton path next to inverted and singular ones, and a
  // count that is not a multiple of the lane width.
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0, 0.3);
  std::vector<Eigen::Matrix3d> F(1003), R(1003);
  for (std::size_t i = 0; i < F.size(); ++i) {
    for (int k = 0; k < 9; ++k) F[i](k / 3, k % 3) = (k % 4 == 0) + g(rng);
    if (i % 7 == 0) F[i].col(0) *= -1;                        // inverted
    if (i % 11 == 0) F[i].col(2) = F[i].col(0) + F[i].col(1); // singular
    if (i % 13 == 0) F[i] *= 1e-160;                          // tiny
  }
  closest_rotations(F.data(), R.data(), F.size());
  for (std::size_t i = 0; i < F.size(); ++i) {
    expect_rotation(R[i]);
    EXPECT_LT((R[i] - closest_rotation(F[i])).cwiseAbs().maxCoeff(), 1e-12) << i;
    check(F[i]);
  }
}
