// The frontend stage's gyro copy (estimator/common/gyro_buffer.hpp): the samples around an interval and
// which of the estimator stage's published biases the matching prior uses.
#include "estimator/common/gyro_buffer.hpp"

#include <gtest/gtest.h>

namespace ovo::estimator {
namespace {

constexpr Timestamp kMs = 1'000'000;

ImuSample sample(Timestamp t_ns) {
  ImuSample s;
  s.t_ns = t_ns;
  s.gyro_radps = Vec3(0.0, 0.0, 0.1);
  return s;
}

Vec3 biasOfFrame(int k) { return Vec3(k + 1, 0, 0); }

class FrontendGyroLead : public ::testing::TestWithParam<int> {};

TEST_P(FrontendGyroLead, ThePriorUpToFrameKUsesTheBiasPublishedAfterFrameKMinus1MinusLead) {
  // Frames every 50 ms; the prior from frame k-1 to k must not depend on how many of
  // update(k-lead) .. update(k-1), which may run on the other thread meanwhile, have published.
  const int lead = GetParam();
  constexpr int kFrames = 20;
  FrontendGyro early(lead), late(lead);  // the estimator stage as far ahead / behind as it may be
  for (FrontendGyro* gyro : {&early, &late})
    for (Timestamp t = 0; t <= kFrames * 50 * kMs; t += 5 * kMs) gyro->add(sample(t));
  int early_published = 0, late_published = 0;
  for (int k = 1; k < kFrames; ++k) {
    // early: update(k-1) is done; late: only update(k-1-lead) is.
    for (; early_published <= k - 1; ++early_published)
      early.publishBias(early_published * 50 * kMs, biasOfFrame(early_published));
    for (; late_published <= k - 1 - lead; ++late_published)
      late.publishBias(late_published * 50 * kMs, biasOfFrame(late_published));
    const Vec3 expected = k - 1 - lead >= 0 ? biasOfFrame(k - 1 - lead) : Vec3::Zero();
    SCOPED_TRACE(::testing::Message() << "lead " << lead << ", frame " << k);
    EXPECT_EQ(early.take((k - 1) * 50 * kMs, k * 50 * kMs).bias_radps, expected);
    EXPECT_EQ(late.take((k - 1) * 50 * kMs, k * 50 * kMs).bias_radps, expected);
  }
}

INSTANTIATE_TEST_SUITE_P(Leads, FrontendGyroLead, ::testing::Values(0, 1, 3, 8));

TEST(FrontendGyro, AnEstimatorStageFarBehindGivesTheNewestBiasPublishedBeforeTheLead) {
  FrontendGyro gyro(1);
  for (Timestamp t = 0; t <= 500 * kMs; t += 5 * kMs) gyro.add(sample(t));
  gyro.publishBias(0, Vec3(1, 0, 0));
  gyro.take(250 * kMs, 300 * kMs);  // frame 250 ms is one frame before 300 ms
  EXPECT_EQ(gyro.take(300 * kMs, 350 * kMs).bias_radps, Vec3(1, 0, 0));
  // Out-of-order publications are ignored; one after the lead's frame is not used yet.
  gyro.publishBias(340 * kMs, Vec3(4, 0, 0));
  gyro.publishBias(100 * kMs, Vec3(9, 0, 0));
  EXPECT_EQ(gyro.take(350 * kMs, 410 * kMs).bias_radps, Vec3(1, 0, 0));  // newest by 300 ms
  EXPECT_EQ(gyro.take(410 * kMs, 460 * kMs).bias_radps, Vec3(4, 0, 0));  // newest by 350 ms
}

TEST(FrontendGyro, TakeHandsOutTheSamplesAroundTheInterval) {
  FrontendGyro gyro(1);
  for (Timestamp t = 0; t <= 100 * kMs; t += 10 * kMs) gyro.add(sample(t));
  const auto w = gyro.take(25 * kMs, 55 * kMs);
  ASSERT_EQ(w.samples.size(), 5u);  // 20 (before 25) .. 60 (after 55)
  EXPECT_EQ(w.samples.front().t_ns, 20 * kMs);
  EXPECT_EQ(w.samples.back().t_ns, 60 * kMs);
}

}  // namespace
}  // namespace ovo::estimator
