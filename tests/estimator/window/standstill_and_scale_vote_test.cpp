// The zero-rate update of the gyro bias from still frames (StandstillBias): known bias, gyro
// white noise at the rig's density, and the start of a motion that the standstill detector
// still took for standing. The initialisation's LiDAR scale vote (voteLidarScale) on range
// ratios with known groups.
#include "estimator/common/two_view.hpp"

#include <gtest/gtest.h>

#include <random>

#include "estimator/window/standstill.hpp"

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
    const Vec3 rate = bias + ramp * Vec3(0.01, 0.0, 0.005) + Vec3(n(rng), n(rng), n(rng));
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

// Range ratios seen at the pinhole row's initialisation (vineyard_row_pinhole, 500 tracks): four
// beams on the near canopy agree with the ground plane's 0.104; nine through a gap onto the next
// row agree with each other on about 0.29, 2.8 times too far.
const std::vector<double> kPinholeRatios = {0.266, 0.100, 0.271, 0.279, 0.101, 0.285, 0.295,
                                            0.306, 0.103, 0.308, 0.241, 0.312, 0.314, 0.104};

TEST(LidarScaleVote, TheLargestGroupWinsWithoutTheGroundPlane) {
  const auto vote = voteLidarScale(kPinholeRatios, std::nullopt, 8, true);
  EXPECT_EQ(vote.outcome, LidarScaleVote::Outcome::kAgreed);
  ASSERT_TRUE(vote.scale.has_value());
  EXPECT_DOUBLE_EQ(*vote.scale, 0.295);  // median of 0.266 ... 0.314
}

TEST(LidarScaleVote, TheGroundPlaneOverrulesALargerGroupItDisagreesWith) {
  const auto vote = voteLidarScale(kPinholeRatios, 0.104, 8, true);
  EXPECT_EQ(vote.outcome, LidarScaleVote::Outcome::kGroundSettled);
  ASSERT_TRUE(vote.scale.has_value());
  EXPECT_DOUBLE_EQ(*vote.scale, 0.103);  // median of 0.100 ... 0.104
  // A ground plane that agrees with the largest group leaves it be.
  EXPECT_EQ(voteLidarScale(kPinholeRatios, 0.3, 8, true).outcome, LidarScaleVote::Outcome::kAgreed);
  // Three beams on the ground are too few to settle it (not min_associations / 2): put off.
  const std::vector<double> three(kPinholeRatios.begin() + 1, kPinholeRatios.end() - 1);
  EXPECT_EQ(voteLidarScale(three, 0.104, 8, true).outcome, LidarScaleVote::Outcome::kPutOff);
}

// Range ratios seen at a pinhole camera's initialisation on the window tests' synthetic drive
// (true scale 0.146): one beam on the ground agrees with the ground plane's 0.147; nine that pass
// under the canopy slab's lower edge land next to its features and agree on about 0.35.
const std::vector<double> kUnderCanopyRatios = {0.145, 0.298, 0.305, 0.321, 0.352,
                                                0.353, 0.362, 0.365, 0.384, 0.411};

TEST(LidarScaleVote, TheGroundPlaneAloneChallengesALargerGroupItDisagreesWith) {
  // Without the ground plane the larger group wins (2.4 times the true scale).
  EXPECT_EQ(voteLidarScale(kUnderCanopyRatios, std::nullopt, 8, true).outcome,
            LidarScaleVote::Outcome::kAgreed);
  // With it, no group big enough agrees with the ground: wait for a later frame ...
  const auto wait = voteLidarScale(kUnderCanopyRatios, 0.147, 8, true);
  EXPECT_EQ(wait.outcome, LidarScaleVote::Outcome::kPutOff);
  EXPECT_FALSE(wait.scale.has_value());
  // ... and when that is no longer allowed, the ground plane's scale, not the LiDAR's.
  const auto overruled = voteLidarScale(kUnderCanopyRatios, 0.147, 8, false);
  EXPECT_EQ(overruled.outcome, LidarScaleVote::Outcome::kOverruled);
  EXPECT_FALSE(overruled.scale.has_value());
  // A ground plane that agrees with the larger group leaves it be.
  const auto agreed = voteLidarScale(kUnderCanopyRatios, 0.36, 8, true);
  EXPECT_EQ(agreed.outcome, LidarScaleVote::Outcome::kAgreed);
  ASSERT_TRUE(agreed.scale.has_value());
  EXPECT_NEAR(*agreed.scale, 0.353, 0.01);
}

TEST(LidarScaleVote, ATieIsPutOffThenTheNearestSurfacesWin) {
  const std::vector<double> tie = {0.30, 0.10, 0.31, 0.101, 0.29, 0.102, 0.305, 0.099, 0.295};
  EXPECT_EQ(voteLidarScale(tie, std::nullopt, 8, true).outcome, LidarScaleVote::Outcome::kPutOff);
  const auto forced = voteLidarScale(tie, std::nullopt, 8, false);
  EXPECT_EQ(forced.outcome, LidarScaleVote::Outcome::kForced);
  ASSERT_TRUE(forced.scale.has_value());
  EXPECT_NEAR(*forced.scale, 0.10, 0.002);
  // With a ground plane that agrees with neither group, the ground plane's scale.
  const auto neither = voteLidarScale(tie, 0.2, 8, false);
  EXPECT_EQ(neither.outcome, LidarScaleVote::Outcome::kOverruled);
  EXPECT_FALSE(neither.scale.has_value());
}

TEST(LidarScaleVote, TooFewRatiosGiveNoScale) {
  EXPECT_EQ(voteLidarScale({}, 0.1, 8, true).outcome, LidarScaleVote::Outcome::kTooFew);
  const auto few = voteLidarScale({0.30, 0.31, 0.32, 0.9}, std::nullopt, 8, true);  // 3 < 8 / 2
  EXPECT_EQ(few.outcome, LidarScaleVote::Outcome::kTooFew);
  EXPECT_FALSE(few.scale.has_value());
  // A ground plane that disagrees with too few ratios does not make a tie of them.
  EXPECT_EQ(voteLidarScale({0.30, 0.31, 0.32, 0.9}, 0.1, 8, true).outcome,
            LidarScaleVote::Outcome::kTooFew);
}

}  // namespace
}  // namespace ovo::estimator
