// Known-answer tests of the relative-pose estimator and its RANSAC (frontend/relative_pose.hpp,
// frontend/ransac.hpp) on synthetic wide-angle two-view problems.
#include "frontend/relative_pose.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "common/error.hpp"
#include "common/so3.hpp"
#include "frontend/essential.hpp"
#include "frontend/ransac.hpp"
#include "tests/gpu/two_view_scene.hpp"

namespace ovo::frontend {
namespace {

constexpr double kDeg = M_PI / 180.0;
using Status = RelativePoseResult::Status;

double rotationErrorDeg(const Mat3& A, const Mat3& B) {
  return so3::angle(A.transpose() * B) / kDeg;
}
double directionErrorDeg(const Vec3& a, const Vec3& b) {
  return std::atan2(a.normalized().cross(b.normalized()).norm(),
                    a.normalized().dot(b.normalized())) /
         kDeg;
}

RelativePoseOptions serialOptions(double threshold_rad) {
  RelativePoseOptions o;
  o.backend = "serial";
  o.inlier_threshold_rad = threshold_rad;
  return o;
}

void expectFinite(const RelativePoseResult& r) {
  EXPECT_TRUE(r.R_cur_prev.allFinite());
  EXPECT_TRUE(r.t_cur_prev.allFinite());
  EXPECT_TRUE(std::isfinite(r.median_parallax_deg));
}

TEST(RansacSampling, HypothesisSampleIsDistinctAndDependsOnlyOnSeedAndIndex) {
  for (std::uint64_t k : {0ull, 1ull, 1999ull}) {
    const auto a = sampleIndices(42, k, 100);
    const auto b = sampleIndices(42, k, 100);
    EXPECT_EQ(a, b);
    EXPECT_EQ(std::set<int>(a.begin(), a.end()).size(), 8u);
    for (int i : a) {
      EXPECT_GE(i, 0);
      EXPECT_LT(i, 100);
    }
  }
  EXPECT_NE(sampleIndices(42, 0, 1000), sampleIndices(42, 1, 1000));
  EXPECT_NE(sampleIndices(42, 0, 1000), sampleIndices(43, 0, 1000));
  EXPECT_EQ(sampleIndices(5, 0, 8).size(), 8u);  // n = 8: a permutation
}

TEST(RansacSampling, RequiredIterationsFollowsTheStandardBound) {
  EXPECT_NEAR(requiredIterations(0.7, 0.999), std::log(0.001) / std::log(1 - std::pow(0.7, 8)),
              1e-9);
  EXPECT_EQ(requiredIterations(1.0, 0.999), 1.0);
  EXPECT_TRUE(std::isinf(requiredIterations(0.0, 0.999)));
}

TEST(RelativePose, RansacWith30PercentOutliersReturnsTheTrueInlierSet) {
  test::TwoViewSceneOptions so;
  so.num_matches = 500;
  so.noise_px = 0.0;
  const auto s = test::makeTwoViewScene(so);
  const double thr = 1e-3;
  RelativePoseEstimator estimator(serialOptions(thr));
  const auto r = estimator.estimate(s.b_prev, s.b_cur);
  ASSERT_EQ(r.status, Status::kOk) << toString(r.status);
  EXPECT_LT(rotationErrorDeg(r.R_cur_prev, s.R_cur_prev), 1e-7);
  EXPECT_LT(directionErrorDeg(r.t_cur_prev, s.t_cur_prev), 1e-7);
  EXPECT_NEAR(r.t_cur_prev.norm(), 1.0, 1e-12);
  // Expected set: every true match, plus any outlier that happens to lie on its epipolar circle.
  const Mat3 E = essentialFromMotion(s.R_cur_prev, s.t_cur_prev.normalized());
  int expected = 0, true_inliers_found = 0;
  for (std::size_t i = 0; i < s.b_prev.size(); ++i) {
    const bool in = sphereError(E, s.b_prev[i], s.b_cur[i]) < thr * thr;
    expected += in;
    EXPECT_EQ(r.inliers[i] != 0, in) << "match " << i << " outlier " << int(s.is_outlier[i]);
    true_inliers_found += (!s.is_outlier[i] && r.inliers[i]) ? 1 : 0;
  }
  EXPECT_EQ(true_inliers_found, 350);
  EXPECT_EQ(r.num_inliers, expected);
  EXPECT_EQ(r.iterations, 2000);
}

TEST(RelativePose, NoisyWideAngleProblemIsAccurate) {
  test::TwoViewSceneOptions so;
  so.num_matches = 1000;
  so.noise_px = 0.5;
  const auto s = test::makeTwoViewScene(so);
  RelativePoseEstimator estimator(serialOptions(4e-3));  // ~2.5 sigma at 0.5 px / 305 px/rad
  const auto r = estimator.estimate(s.b_prev, s.b_cur);
  ASSERT_EQ(r.status, Status::kOk) << toString(r.status);
  EXPECT_LT(rotationErrorDeg(r.R_cur_prev, s.R_cur_prev), 0.05);
  EXPECT_LT(directionErrorDeg(r.t_cur_prev, s.t_cur_prev), 1.0);
  int false_inliers = 0;
  for (std::size_t i = 0; i < s.is_outlier.size(); ++i)
    false_inliers += s.is_outlier[i] && r.inliers[i];
  EXPECT_LT(false_inliers, 10);
  EXPECT_GT(r.num_inliers, 650);
  EXPECT_GT(r.median_parallax_deg, 0.3);
}

TEST(RelativePose, AdaptiveStoppingStopsEarlyOnAnEasyProblem) {
  test::TwoViewSceneOptions so;
  so.num_matches = 400;
  so.outlier_ratio = 0.1;
  so.noise_px = 0.3;
  const auto s = test::makeTwoViewScene(so);
  RelativePoseOptions o = serialOptions(4e-3);
  o.adaptive = true;
  o.confidence = 0.999;
  RelativePoseEstimator estimator(o);
  const auto r = estimator.estimate(s.b_prev, s.b_cur);
  ASSERT_EQ(r.status, Status::kOk);
  EXPECT_LT(r.iterations, o.max_iterations);
  EXPECT_EQ(r.iterations % 128, 0);  // stops at the end of a block
  EXPECT_LT(rotationErrorDeg(r.R_cur_prev, s.R_cur_prev), 0.05);
}

TEST(RelativePose, PureRotationIsLowParallaxWithTheRotationAndZeroTranslation) {
  for (double noise_px : {0.0, 0.5}) {
    test::TwoViewSceneOptions so;
    so.num_matches = 300;
    so.noise_px = noise_px;
    so.t_cur_prev = Vec3::Zero();
    const auto s = test::makeTwoViewScene(so);
    RelativePoseEstimator estimator(serialOptions(4e-3));
    const auto r = estimator.estimate(s.b_prev, s.b_cur);
    expectFinite(r);
    ASSERT_EQ(r.status, Status::kLowParallax) << toString(r.status) << " noise " << noise_px;
    EXPECT_EQ(r.t_cur_prev, Vec3::Zero());
    EXPECT_LT(rotationErrorDeg(r.R_cur_prev, s.R_cur_prev), noise_px > 0 ? 0.05 : 1e-9);
    EXPECT_LT(r.median_parallax_deg, 0.3);
    int false_inliers = 0;
    for (std::size_t i = 0; i < s.is_outlier.size(); ++i)
      false_inliers += s.is_outlier[i] && r.inliers[i];
    EXPECT_LT(false_inliers, 5);
  }
}

TEST(RelativePose, TooFewMatchesGivesStatusAndNoNaN) {
  test::TwoViewSceneOptions so;
  so.num_matches = 7;
  so.outlier_ratio = 0.0;
  const auto s = test::makeTwoViewScene(so);
  RelativePoseEstimator estimator(serialOptions(1e-3));
  const auto r = estimator.estimate(s.b_prev, s.b_cur);
  EXPECT_EQ(r.status, Status::kTooFewMatches);
  EXPECT_EQ(r.inliers.size(), 7u);
  expectFinite(r);
  const auto empty = estimator.estimate({}, {});
  EXPECT_EQ(empty.status, Status::kTooFewMatches);
}

TEST(RelativePose, GarbageInputGivesNoConsensusAndNoNaN) {
  std::mt19937_64 rng(3);
  std::vector<Vec3> bp, bc;
  for (int i = 0; i < 200; ++i) {
    bp.push_back(test::randomDirectionInCap(rng, M_PI));
    bc.push_back(test::randomDirectionInCap(rng, M_PI));
  }
  RelativePoseEstimator estimator(serialOptions(1e-3));
  const auto r = estimator.estimate(bp, bc);
  EXPECT_EQ(r.status, Status::kNoConsensus) << toString(r.status);
  expectFinite(r);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<Vec3> nans(50, Vec3(nan, nan, nan)), zeros(50, Vec3::Zero());
  for (const auto* v : {&nans, &zeros}) {
    const auto rn = estimator.estimate(*v, *v);
    EXPECT_EQ(rn.status, Status::kNoConsensus);
    expectFinite(rn);
    EXPECT_EQ(rn.num_inliers, 0);
  }
}

TEST(RelativePose, OptionsAreReadFromConfigAndBadBackendIsAnError) {
  const Config cfg = Config::fromString(
      "ransac:\n  backend: threads\n  max_iterations: 500\n  adaptive: true\n"
      "  inlier_threshold_rad: 0.002\n  seed: 7\n  min_inliers: 30\n  min_parallax_deg: 0.5\n");
  const auto o = readRelativePoseOptions(cfg);
  EXPECT_EQ(o.backend, "threads");
  EXPECT_EQ(o.max_iterations, 500);
  EXPECT_TRUE(o.adaptive);
  EXPECT_DOUBLE_EQ(o.inlier_threshold_rad, 0.002);
  EXPECT_EQ(o.seed, 7u);
  EXPECT_EQ(o.min_inliers, 30);
  EXPECT_DOUBLE_EQ(o.min_parallax_deg, 0.5);
  EXPECT_NO_THROW(cfg.checkAllUsed());
  EXPECT_THROW(readRelativePoseOptions(Config::fromString("ransac:\n  backend: cuda\n")), Error);
  RelativePoseOptions bad;
  bad.backend = "cuda";
  EXPECT_THROW(RelativePoseEstimator{bad}, Error);
}

}  // namespace
}  // namespace ovo::frontend
