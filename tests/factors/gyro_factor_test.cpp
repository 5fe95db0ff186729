#include <gtest/gtest.h>

#include "factors/gyro_preintegration.hpp"
#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::quatBlock;
using testing::samplesOf;
using testing::vecBlock;

TEST(GyroPreintegration, ConstantRateGivesExactRotationBetweenSampleTimes) {
  const Vec3 w(0.3, -0.2, 0.9), b(0.01, 0.02, -0.03);
  const auto samples = samplesOf([&](double) -> Vec3 { return w + b; }, 0, 2'000'000'000);
  // Frame times between sample times: the rate is interpolated there.
  const Timestamp t_i = 101'234'567, t_j = 1'303'456'789;
  const GyroPreintegration pre(samples, t_i, t_j, b);
  EXPECT_EQ(pre.status(), GyroPreintegration::Status::kOk);
  EXPECT_EQ(pre.numSamples(), 240);
  const Mat3 expected = so3::exp(w * toSeconds(t_j - t_i));
  EXPECT_LT(so3::angle(pre.deltaR().transpose() * expected), 1e-12);
}

TEST(GyroPreintegration, LinearRateAboutFixedAxisIsIntegratedExactly) {
  // Rotations about one axis commute; the trapezoidal rule is exact for a rate linear in time,
  // including the interpolated pieces at both frame times.
  const Vec3 axis = Vec3(1, 2, -1).normalized();
  const auto rate = [&](double t) -> Vec3 { return (0.2 + 1.5 * t) * axis; };
  const auto samples = samplesOf(rate, 0, 3'000'000'000);
  const Timestamp t_i = 250'000'001, t_j = 2'123'456'789;
  const GyroPreintegration pre(samples, t_i, t_j, Vec3::Zero());
  const double ti = toSeconds(t_i), tj = toSeconds(t_j);
  const double angle = 0.2 * (tj - ti) + 0.75 * (tj * tj - ti * ti);
  EXPECT_LT(so3::angle(pre.deltaR().transpose() * so3::exp(angle * axis)), 1e-11);
}

TEST(GyroPreintegration, CovarianceAtRestIsNoiseDensitySquaredTimesDuration) {
  const auto samples = samplesOf([](double) -> Vec3 { return Vec3::Zero(); }, 0, 2'000'000'000);
  GyroPreintegrationOptions opt;
  opt.noise_density = 2e-3;
  const GyroPreintegration pre(samples, 0, 1'500'000'000, Vec3::Zero(), opt);
  const Mat3 expected = opt.noise_density * opt.noise_density * 1.5 * Mat3::Identity();
  EXPECT_LT((pre.covariance() - expected).norm(), 1e-15);
  const Mat3 info = pre.sqrtInformation().transpose() * pre.sqrtInformation();
  EXPECT_LT((info * pre.covariance() - Mat3::Identity()).norm(), 1e-6);
}

TEST(GyroPreintegration, BiasJacobianMatchesRepropagation) {
  const auto rate = [](double t) -> Vec3 {
    return Vec3(0.5 * std::sin(3 * t), 0.8 * std::cos(2 * t), 0.3 + 0.4 * t);
  };
  const auto samples = samplesOf(rate, 0, 2'000'000'000);
  const Vec3 b_bar(0.01, -0.02, 0.005);
  const GyroPreintegration pre(samples, 100'000'000, 1'100'000'000, b_bar);
  const auto f = [&](const Eigen::VectorXd& b) -> Eigen::VectorXd {
    GyroPreintegration other = pre;
    other.repropagate(b_bar + Vec3(b));
    return so3::log(pre.deltaR().transpose() * other.deltaR());
  };
  OVO_EXPECT_JACOBIAN_NEAR(pre.biasJacobian(), ovo::test::numericJacobian(f, Vec3::Zero()), 1e-6);
  // The first-order correction is good to second order for a small bias change.
  const Vec3 db(0.002, -0.001, 0.003);
  GyroPreintegration moved = pre;
  moved.repropagate(b_bar + db);
  EXPECT_LT(so3::angle(pre.deltaR(b_bar + db).transpose() * moved.deltaR()), 1e-6);
  EXPECT_FALSE(pre.needsRepropagation(b_bar + db, 0.02));
  EXPECT_TRUE(pre.needsRepropagation(b_bar + Vec3(0.05, 0, 0), 0.02));
}

TEST(GyroPreintegration, RepropagateEqualsFreshIntegration) {
  const auto rate = [](double t) -> Vec3 { return Vec3(std::sin(t), 0.2, -0.5 * t); };
  const auto samples = samplesOf(rate, 0, 2'000'000'000);
  GyroPreintegration pre(samples, 3'000'000, 1'700'000'000, Vec3::Zero());
  const Vec3 b(0.03, -0.01, 0.02);
  pre.repropagate(b);
  const GyroPreintegration fresh(samples, 3'000'000, 1'700'000'000, b);
  EXPECT_LT((pre.deltaR() - fresh.deltaR()).norm(), 1e-14);
  EXPECT_LT((pre.biasJacobian() - fresh.biasJacobian()).norm(), 1e-14);
  EXPECT_LT((pre.covariance() - fresh.covariance()).norm(), 1e-20);
}

TEST(GyroPreintegration, GapIsReportedAndInflatesCovariance) {
  auto samples = samplesOf([](double) -> Vec3 { return Vec3(0, 0, 0.5); }, 0, 2'000'000'000);
  const GyroPreintegration full(samples, 0, 1'000'000'000, Vec3::Zero());
  // Remove 0.30 s..0.50 s: the samples around the hole are 0.205 s apart.
  std::erase_if(samples,
                [](const ImuSample& s) { return s.t_ns > 300'000'000 && s.t_ns < 505'000'000; });
  const GyroPreintegration gappy(samples, 0, 1'000'000'000, Vec3::Zero());
  EXPECT_EQ(full.status(), GyroPreintegration::Status::kOk);
  EXPECT_EQ(gappy.status(), GyroPreintegration::Status::kGap);
  EXPECT_NEAR(gappy.longestGapSeconds(), 0.205, 1e-9);
  EXPECT_GT(gappy.covariance().trace(), 100.0 * full.covariance().trace());
  // A constant rate is still integrated exactly across the hole.
  EXPECT_LT(so3::angle(gappy.deltaR().transpose() * full.deltaR()), 1e-12);
}

TEST(GyroPreintegration, UncoveredEndsAndNoDataAreReported) {
  const auto samples = samplesOf([](double) -> Vec3 { return Vec3(0.1, 0, 0); }, 0, 1'000'000'000);
  const GyroPreintegration late_end(samples, 500'000'000, 1'300'000'000, Vec3::Zero());
  EXPECT_EQ(late_end.status(), GyroPreintegration::Status::kGap);
  EXPECT_NEAR(late_end.gapSeconds(), 0.3, 1e-9);
  const GyroPreintegration outside(samples, 2'000'000'000, 3'000'000'000, Vec3::Zero());
  EXPECT_EQ(outside.status(), GyroPreintegration::Status::kNoData);
  const GyroPreintegration empty({}, 0, 1'000'000'000, Vec3::Zero());
  EXPECT_EQ(empty.status(), GyroPreintegration::Status::kNoData);
  EXPECT_TRUE(empty.covariance().allFinite());
  EXPECT_TRUE(empty.sqrtInformation().allFinite());
}

TEST(GyroFactor, ZeroResidualWhenPosesAgreeWithBiasCorrectedRotation) {
  std::mt19937 rng(5);
  const auto rate = [](double t) -> Vec3 { return Vec3(0.4 * std::sin(2 * t), -0.3, 0.6 * t); };
  const auto samples = samplesOf(rate, 0, 2'000'000'000);
  const Vec3 b_bar(0.01, 0.0, -0.01);
  auto pre = std::make_shared<GyroPreintegration>(samples, 0, 1'000'000'000, b_bar);
  const Vec3 b_g = b_bar + Vec3(0.002, -0.003, 0.001);
  const Quat q_i = testing::randomQuat(rng);
  const Quat q_j = q_i * Quat(pre->deltaR(b_g));
  const GyroFactor f(pre);
  EXPECT_LT(testing::evaluate(f, {quatBlock(q_i), quatBlock(q_j), vecBlock(b_g)}).norm(), 1e-8);
}

TEST(GyroFactor, JacobiansMatchNumeric) {
  std::mt19937 rng(6);
  const auto rate = [](double t) -> Vec3 { return Vec3(0.4 * std::sin(2 * t), -0.3, 0.6 * t); };
  const auto samples = samplesOf(rate, 0, 2'000'000'000);
  auto pre = std::make_shared<GyroPreintegration>(samples, 0, 1'000'000'000, Vec3::Zero());
  const GyroFactor f(pre);
  for (int trial = 0; trial < 10; ++trial) {
    const Quat q_i = testing::randomQuat(rng);
    const Quat q_j = q_i * Quat(pre->deltaR()) * testing::randomQuat(rng, 0.3);
    const std::vector<std::vector<double>> blocks = {quatBlock(q_i), quatBlock(q_j),
                                                     vecBlock(testing::randomVec(rng, 0.05))};
    // Whitened residuals are large (sigma ~ 1e-4 rad): compare relative to their scale.
    testing::expectJacobiansMatch(f, blocks, {true, true, false}, 2e-6);
  }
}

TEST(BiasRandomWalkFactor, ResidualAndJacobians) {
  const BiasRandomWalkFactor f(2e-5, 4.0);  // sigma over 4 s = 4e-5 rad/s
  const std::vector<std::vector<double>> blocks = {{0.01, 0.02, 0.03}, {0.01, 0.02 + 4e-5, 0.03}};
  const Eigen::VectorXd r = testing::evaluate(f, blocks);
  EXPECT_NEAR(r[1], 1.0, 1e-9);
  EXPECT_NEAR(r[0], 0.0, 1e-12);
  testing::expectJacobiansMatch(f, blocks, {false, false}, 1e-6);
}

}  // namespace
}  // namespace ovo::factors
