// The start's LiDAR scale vote (voteLidarScale) on range ratios with known groups.
#include <gtest/gtest.h>

#include <optional>
#include <vector>

#include "estimator/window/lidar_ranges.hpp"

namespace ovo::estimator {
namespace {

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
