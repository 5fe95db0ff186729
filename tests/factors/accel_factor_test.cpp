#include "factors/accel_factor.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/so3.hpp"
#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::quatBlock;

// A body that turns at a constant body rate, weaves sideways and climbs with a constant
// acceleration, under a gravity tilted off the world's z (the window's world is its first
// keyframe's, not levelled), with an accelerometer and a gyro bias.
struct Motion {
  Mat3 R0 = so3::exp(Vec3(0.2, -0.1, 0.7));
  Vec3 w_B = Vec3(0.1, -0.2, 0.5);  // rad/s
  Vec3 b_g = Vec3(0.01, -0.005, 0.002);
  Vec3 b_a = Vec3(0.03, -0.02, 0.04);
  double state[kGravityStateSize] = {0.05, -0.03, 0.03, -0.02, 0.04};  // alpha, beta, b_a
  double g = 9.81;

  Mat3 R(double t) const { return R0 * so3::exp(w_B * t); }
  Vec3 p(double t) const { return {0.8 * t, 0.1 * std::sin(2.0 * t), 0.05 * t * t}; }
  Vec3 a(double t) const { return {0.0, -0.4 * std::sin(2.0 * t), 0.1}; }
  std::vector<ImuSample> samples(double rate_hz, double until_s) const {
    std::vector<ImuSample> out;
    for (int i = 0; i / rate_hz <= until_s; ++i) {
      const double t = i / rate_hz;
      ImuSample s;
      s.t_ns = fromSeconds(t);
      s.gyro_radps = w_B + b_g;
      s.accel_mps2 = R(t).transpose() * (a(t) - g * gravityDirection(state)) + b_a;
      out.push_back(s);
    }
    return out;
  }
};

std::vector<double> pos(const Vec3& p) { return {p.x(), p.y(), p.z()}; }
std::vector<double> stateBlock(const double* s) { return {s, s + kGravityStateSize}; }

TEST(AccelerationFactor, TheTrueMotionAndGravityGiveNoResidualATiltOfOneDegreeGivesGTimesIt) {
  const Motion m;
  const auto samples = m.samples(200.0, 1.0);
  const double t0 = 0.1, t1 = 0.33, t2 = 0.52;  // between samples
  const auto first = integrateAccel(samples, fromSeconds(t0), fromSeconds(t1), m.b_g);
  const auto second = integrateAccel(samples, fromSeconds(t1), fromSeconds(t2), m.b_g);
  ASSERT_TRUE(first && second);
  EXPECT_NEAR(first->dt_s, 0.23, 1e-9);
  const AccelerationFactor f(*first, *second, m.g, 1.0);
  const auto blocks = [&](const Mat3& R1) {
    return std::vector<std::vector<double>>{quatBlock(Quat(R1)), pos(m.p(t0)), pos(m.p(t1)),
                                            pos(m.p(t2)), stateBlock(m.state)};
  };
  // The trapezoids over 5 ms steps of a sideways weave at 2 rad/s: within a few mm/s^2.
  EXPECT_LT(testing::evaluate(f, blocks(m.R(t1))).norm(), 3e-3);
  // The keyframe tilted by 1 degree about the world's x: gravity seen 1 degree off, 0.171 m/s^2.
  const double tilt = 1.0 * M_PI / 180.0;
  const Mat3 R_tilted = so3::exp(Vec3(tilt, 0.0, 0.0)) * m.R(t1);
  EXPECT_NEAR(testing::evaluate(f, blocks(R_tilted)).norm(), m.g * tilt, 5e-3);
  // A turn about gravity itself (yaw) turns only the body's own acceleration (at most 0.4 m/s^2
  // here): 0.3 rad of yaw moves the residual by at most 0.12 m/s^2, where a tilt of 0.3 rad
  // would move it by 2.9.
  const Mat3 R_yawed = so3::exp(0.3 * gravityDirection(m.state)) * m.R(t1);
  EXPECT_LT(testing::evaluate(f, blocks(R_yawed)).norm(), 0.3 * 0.4 + 3e-3);
  // The accelerometer's bias is part of the state: the true motion with the bias left out is
  // |b_a| = 0.054 m/s^2 off.
  double no_bias[kGravityStateSize] = {m.state[0], m.state[1], 0.0, 0.0, 0.0};
  auto b = blocks(m.R(t1));
  b[4] = stateBlock(no_bias);
  EXPECT_NEAR(testing::evaluate(f, b).norm(), m.b_a.norm(), 4e-3);
}

TEST(AccelerationFactor, ThePositionsNoiseLoosensTheFactorAsTheKeyframesGetCloser) {
  // A 1 degree tilt is 0.171 m/s^2 off. With equal steps dt the second difference carries
  // sqrt(6) sigma_p / dt^2 of the positions' noise: 0.0612 m/s^2 for 1 mm over 0.2 s steps,
  // 0.245 over 0.1 s; added in quadrature to the specific force's own.
  const Motion m;
  const auto samples = m.samples(200.0, 1.0);
  const double tilt = 1.0 * M_PI / 180.0;
  for (const double dt : {0.2, 0.1}) {
    const auto first = integrateAccel(samples, fromSeconds(0.3 - dt), fromSeconds(0.3), m.b_g);
    const auto second = integrateAccel(samples, fromSeconds(0.3), fromSeconds(0.3 + dt), m.b_g);
    ASSERT_TRUE(first && second);
    const AccelerationFactor f(*first, *second, m.g, 0.02, 0.001);
    const Mat3 R_tilted = so3::exp(Vec3(0.0, tilt, 0.0)) * m.R(0.3);
    const double sigma = std::hypot(0.02, std::sqrt(6.0) * 0.001 / (dt * dt));
    const Eigen::VectorXd r = testing::evaluate(
        f, {quatBlock(Quat(R_tilted)), pos(m.p(0.3 - dt)), pos(m.p(0.3)), pos(m.p(0.3 + dt)),
            stateBlock(m.state)});
    EXPECT_NEAR(r.norm(), m.g * tilt / sigma, 0.05 * m.g * tilt / sigma) << "dt " << dt;
  }
}

TEST(AccelerationFactor, JacobiansMatchNumeric) {
  const Motion m;
  const auto samples = m.samples(200.0, 1.0);
  const auto first = integrateAccel(samples, fromSeconds(0.0), fromSeconds(0.2), m.b_g);
  const auto second = integrateAccel(samples, fromSeconds(0.2), fromSeconds(0.5), m.b_g);
  ASSERT_TRUE(first && second);
  const AccelerationFactor f(*first, *second, m.g, 0.1);
  std::mt19937 rng(4);
  for (int trial = 0; trial < 5; ++trial) {
    const double s[kGravityStateSize] = {0.1 * trial, -0.05 * trial, 0.01, 0.02, -0.03};
    testing::expectJacobiansMatch(f,
                                  {quatBlock(testing::randomQuat(rng)), pos(m.p(0.0)),
                                   pos(m.p(0.2) + Vec3(0.01, 0.0, 0.0)), pos(m.p(0.5)),
                                   stateBlock(s)},
                                  {true, false, false, false, false}, 1e-5);
  }
  const AccelBiasPriorFactor prior(0.1);
  testing::expectJacobiansMatch(prior, {stateBlock(m.state)}, {false}, 1e-6);
  EXPECT_NEAR(testing::evaluate(prior, {stateBlock(m.state)})[2], 0.4, 1e-12);
}

TEST(AccelerationFactor, GravityAnglesRoundTrip) {
  for (const Vec3& d : {Vec3(0, 0, -1), Vec3(0.1, -0.2, -0.97), Vec3(-0.3, 0.25, -0.9)}) {
    double s[kGravityStateSize] = {};
    setGravityDirection(d, s);
    EXPECT_LT((gravityDirection(s) - d.normalized()).norm(), 1e-12);
  }
}

TEST(AccelerationFactor, AnIntervalTheSamplesDoNotCoverOrWithoutAnAccelerometerGivesNone) {
  const Motion m;
  auto samples = m.samples(200.0, 1.0);
  EXPECT_FALSE(integrateAccel(samples, fromSeconds(0.5), fromSeconds(1.2), m.b_g));  // past the end
  EXPECT_FALSE(integrateAccel(samples, fromSeconds(0.5), fromSeconds(0.5), m.b_g));  // empty
  auto gap = samples;
  gap.erase(gap.begin() + 100, gap.begin() + 130);  // 150 ms without a sample
  EXPECT_FALSE(integrateAccel(gap, fromSeconds(0.4), fromSeconds(0.8), m.b_g));
  EXPECT_TRUE(integrateAccel(gap, fromSeconds(0.7), fromSeconds(0.9), m.b_g));
  for (auto& s : samples) s.accel_mps2.setZero();  // a gyro-only IMU
  EXPECT_FALSE(integrateAccel(samples, fromSeconds(0.2), fromSeconds(0.4), m.b_g));
}

}  // namespace
}  // namespace ovo::factors
