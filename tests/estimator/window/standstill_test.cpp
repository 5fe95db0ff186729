// The zero-rate update of the gyro bias from still frames (StandstillBias): known bias, gyro
// white noise at the rig's density, and the start of a motion that the standstill detector
// still took for standing.
#include "estimator/window/standstill.hpp"

#include <gtest/gtest.h>

#include <random>

#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

constexpr double kNoiseDensity = 1.7e-4;  // rad/s/sqrt(Hz)
constexpr double kWalk = 2e-5;            // rad/s^2/sqrt(Hz)
constexpr double kFrameS = 0.05;          // 20 Hz camera

/// Still frames (rate = bias + noise) for still_s, then frames whose rate ramps up to
/// (0.01, 0, 0.005) rad/s over onset_s (the robot starts to move, still below the gates).
void feed(StandstillBias& z, const Vec3& bias, double still_s, double onset_s, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, kNoiseDensity / std::sqrt(kFrameS));
  const int still = static_cast<int>(std::lround(still_s / kFrameS));
  const int onset = static_cast<int>(std::lround(onset_s / kFrameS));
  for (int k = 0; k < still + onset; ++k) {
    const double ramp = k < still ? 0.0 : static_cast<double>(k - still + 1) / onset;
    const Vec3 rate = bias + ramp * Vec3(0.01, 0.0, 0.005) + ovo::test::draw3(n, rng);
    z.add(fromSeconds(1.0 + (k + 1) * kFrameS), rate * kFrameS, kFrameS);
  }
}

TEST(StandstillBias, MeanRateOfStillFramesIsTheBiasWithTheNoiseSigma) {
  const Vec3 bias(0.004, -0.003, 0.005);
  StandstillBias z(kNoiseDensity, kWalk, 0.3);
  feed(z, bias, 2.0, 0.0, 1);
  z.endStreak();
  const auto e = z.estimate(0.25);
  ASSERT_TRUE(e.has_value());
  EXPECT_NEAR(e->time_s, 1.7, 1e-9);  // the last 0.3 s are left out
  // sigma = 1.7e-4 / sqrt(1.7 s) = 1.3e-4 rad/s (the walk adds little).
  EXPECT_NEAR(e->sigma_radps, 1.3e-4, 0.2e-4);
  EXPECT_LT((e->bias_radps - bias).cwiseAbs().maxCoeff(), 4.0 * e->sigma_radps);
  EXPECT_NEAR(e->chi2_dof, 1.0, 0.3);
}

TEST(StandstillBias, LeavesOutTheStartOfTheMotionAtTheEndOfAStreak) {
  // 1 s still, then 0.25 s of starting motion taken for still (the steep_slope start: the window
  // began with a bias 1.5e-3 rad/s off in x).
  const Vec3 bias(0.001, -0.01, 0.007);
  StandstillBias trimmed(kNoiseDensity, kWalk, 0.3), untrimmed(kNoiseDensity, kWalk, 0.0);
  feed(trimmed, bias, 1.0, 0.25, 2);
  feed(untrimmed, bias, 1.0, 0.25, 2);
  trimmed.endStreak();
  untrimmed.endStreak();
  const auto t = trimmed.estimate(0.25), u = untrimmed.estimate(0.25);
  ASSERT_TRUE(t && u);
  EXPECT_LT((t->bias_radps - bias).norm(), 4e-4) << t->bias_radps.transpose();
  EXPECT_GT((u->bias_radps - bias).norm(), 1e-3) << u->bias_radps.transpose();
  // Without the trim the scatter of the moving frames shows: the sigma grows from the noise's
  // 1.7e-4 / sqrt(1.25 s) so that the error is within 4 sigma (it is 8 of the noise's sigma).
  const double nominal = kNoiseDensity / std::sqrt(u->time_s);
  const double error = (u->bias_radps - bias).cwiseAbs().maxCoeff();
  EXPECT_GT(u->chi2_dof, 4.0);
  EXPECT_GT(error, 6.0 * nominal);
  EXPECT_LT(error, 4.0 * u->sigma_radps);
}

TEST(StandstillBias, StreaksAddUpAndTooShortGivesNothing) {
  const Vec3 bias(0.002, 0.001, -0.003);
  StandstillBias z(kNoiseDensity, kWalk, 0.3);
  feed(z, bias, 0.4, 0.0, 3);
  z.endStreak();
  EXPECT_FALSE(z.estimate(0.25).has_value());  // 0.1 s left after the trim
  feed(z, bias, 0.5, 0.0, 4);
  EXPECT_TRUE(z.inStreak());
  const auto open = z.estimate(0.25);  // the open streak counts untrimmed
  ASSERT_TRUE(open.has_value());
  EXPECT_NEAR(open->time_s, 0.6, 1e-9);
  z.reset();
  EXPECT_FALSE(z.estimate(0.0).has_value());
}

// An hour parked at 20 Hz: the zero-rate update holds only the frames its end may still trim
// (trim_s of them), the rest as sums, and its estimate is the mean over every frame.
TEST(StandstillBias, AnHourParkedHoldsOnlyTheFramesItMayTrim) {
  StandstillBias z(kNoiseDensity, kWalk, 0.3);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, kNoiseDensity / std::sqrt(kFrameS));
  const Vec3 bias(0.002, -0.001, 0.0005);
  Vec3 sum = Vec3::Zero();
  const int frames = 72000;
  for (int k = 0; k < frames; ++k) {
    const Vec3 rotation = (bias + ovo::test::draw3(n, rng)) * kFrameS;
    sum += rotation;
    z.add(fromSeconds(1.0 + (k + 1) * kFrameS), rotation, kFrameS);
  }
  EXPECT_LE(z.framesHeld(), 7u);  // 0.3 s at 20 Hz, and the newest
  const auto e = z.estimate(1.0);
  ASSERT_TRUE(e.has_value());
  EXPECT_NEAR(e->time_s, frames * kFrameS, 1e-6);
  EXPECT_LT((e->bias_radps - sum / (frames * kFrameS)).norm(), 1e-12);
  EXPECT_NEAR(e->chi2_dof, 1.0, 0.05);  // white noise at the given density
}

}  // namespace
}  // namespace ovo::estimator
