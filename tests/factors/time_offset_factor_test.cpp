// The time-offset gyro factor: its Jacobians against central differences, and known answers on
// synthetic rates (an offset seen through angular acceleration; none seen at a constant rate).
#include "factors/time_offset_factor.hpp"

#include <gtest/gtest.h>

#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::quatBlock;
using testing::samplesOf;
using testing::vecBlock;

// A turn that speeds up and swings across axes: the rate changes over every interval.
Vec3 swingingRate(double t) {
  return Vec3(0.3 * std::sin(2.1 * t), 0.2 + 0.4 * std::cos(1.3 * t),
              0.8 * std::sin(0.9 * t + 0.4));
}

TEST(GyroTimeOffsetFactor, JacobiansMatchNumericDifferences) {
  std::mt19937 rng(7);
  const auto samples = samplesOf(swingingRate, 0, 3'000'000'000);
  const Vec3 b_lin(0.01, -0.02, 0.005);
  const double td_lin = 0.02;
  auto pre = std::make_shared<GyroPreintegration>(samples, 1'000'000'000 - fromSeconds(td_lin),
                                                  1'400'000'000 - fromSeconds(td_lin), b_lin);
  const GyroTimeOffsetFactor f(pre, td_lin);
  for (int trial = 0; trial < 5; ++trial) {
    const Quat q_i = testing::randomQuat(rng), q_j = testing::randomQuat(rng);
    const Vec3 b = b_lin + testing::randomVec(rng, 0.01);
    std::uniform_real_distribution<double> u(-0.05, 0.05);
    const std::vector<std::vector<double>> blocks = {
        quatBlock(q_i), quatBlock(q_j), vecBlock(b), {td_lin + u(rng)}};
    testing::expectJacobiansMatch(f, blocks, {true, true, false, false}, 1e-6);
  }
}

TEST(GyroTimeOffsetFactor, AtItsLinearisationOffsetItIsTheGyroFactor) {
  std::mt19937 rng(3);
  const auto samples = samplesOf(swingingRate, 0, 3'000'000'000);
  const Vec3 b_lin(0.01, -0.02, 0.005);
  auto pre = std::make_shared<GyroPreintegration>(samples, 900'000'000, 1'300'000'000, b_lin);
  const GyroTimeOffsetFactor with_offset(pre, 0.015);
  const GyroFactor plain(pre);
  const std::vector<std::vector<double>> blocks = {quatBlock(testing::randomQuat(rng)),
                                                   quatBlock(testing::randomQuat(rng)),
                                                   vecBlock(b_lin + testing::randomVec(rng, 0.01)),
                                                   {0.015}};
  const auto a = testing::tangentJacobians(with_offset, blocks, {true, true, false, false});
  const std::vector<std::vector<double>> plain_blocks(blocks.begin(), blocks.end() - 1);
  const auto b = testing::tangentJacobians(plain, plain_blocks, {true, true, false});
  EXPECT_LT(
      (testing::evaluate(with_offset, blocks) - testing::evaluate(plain, plain_blocks)).norm(),
      1e-9);
  for (int k = 0; k < 3; ++k) EXPECT_LT((a[k] - b[k]).norm(), 1e-9 * (1.0 + b[k].norm())) << k;
}

// Keyframes at image stamps 1.0 s and 1.35 s whose images were taken td_true earlier on the gyro
// clock; the window's poses are the true ones. The preintegration was made at td_lin = 0.
struct OffsetCase {
  double td_true;
  std::function<Vec3(double)> rate;
  std::vector<double> residualNorms(const std::vector<double>& tds) const {
    const auto samples = samplesOf(rate, 0, 3'000'000'000);
    const Timestamp t_i = 1'000'000'000, t_j = 1'350'000'000;
    auto made = std::make_shared<GyroPreintegration>(samples, t_i, t_j, Vec3::Zero());
    const GyroPreintegration truth(samples, t_i - fromSeconds(td_true), t_j - fromSeconds(td_true),
                                   Vec3::Zero());
    const GyroTimeOffsetFactor f(made, 0.0);
    std::vector<double> out;
    for (double td : tds) {
      const auto r = testing::evaluate(f, {quatBlock(Quat::Identity()),
                                           quatBlock(Quat(truth.deltaR())),
                                           vecBlock(Vec3::Zero()),
                                           {td}});
      out.push_back(r.norm());
    }
    return out;
  }
};

TEST(GyroTimeOffsetFactor, ItsResidualVanishesAtTheTrueOffset) {
  for (double td_true : {0.03, -0.04, 0.008}) {
    SCOPED_TRACE(td_true);
    const OffsetCase c{td_true, swingingRate};
    // Scan td over +-60 ms in 0.5 ms steps: the smallest residual is at the true offset.
    std::vector<double> tds;
    for (double td = -0.06; td <= 0.06 + 1e-12; td += 0.0005) tds.push_back(td);
    const auto r = c.residualNorms(tds);
    const auto best = std::min_element(r.begin(), r.end()) - r.begin();
    EXPECT_NEAR(tds[best], td_true, 0.001);
    // ... and the offset is seen: ignoring it (td = 0) leaves many sigmas of residual.
    EXPECT_GT(c.residualNorms({0.0})[0], 20.0 * r[best]);
  }
}

TEST(GyroTimeOffsetFactor, AConstantRateDoesNotSeeTheOffset) {
  const OffsetCase c{0.03, [](double) -> Vec3 { return Vec3(0.2, -0.5, 0.9); }};
  const auto r = c.residualNorms({-0.05, 0.0, 0.03, 0.05});
  for (double v : r) EXPECT_LT(v, 1e-6);
}

}  // namespace
}  // namespace ovo::factors
