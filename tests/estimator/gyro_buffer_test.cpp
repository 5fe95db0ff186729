// The frontend stage's gyro copy (estimator/gyro_buffer.hpp): the samples around an interval and
// which of the estimator stage's published biases the matching prior uses.
#include "estimator/gyro_buffer.hpp"

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

TEST(FrontendGyro, ThePriorUpToFrameKUsesTheBiasPublishedAfterFrameKMinus2) {
  // Frames every 50 ms; the prior from frame k-1 to k must not depend on whether update(k-1),
  // which runs on the other thread at the same time, has published yet.
  FrontendGyro early, late;  // frame 2's bias published before / after frame 3's prior is taken
  for (FrontendGyro* gyro : {&early, &late}) {
    for (Timestamp t = 0; t <= 200 * kMs; t += 5 * kMs) gyro->add(sample(t));
    EXPECT_EQ(gyro->take(0, 50 * kMs).bias_radps, Vec3::Zero());  // nothing published yet
    gyro->publishBias(0, Vec3(1, 0, 0));                          // after frame 0
    gyro->publishBias(50 * kMs, Vec3(2, 0, 0));                   // after frame 1
    // Frame 2's prior (from frame 1): frame 0's bias, although frame 1's is already there.
    EXPECT_EQ(gyro->take(50 * kMs, 100 * kMs).bias_radps, Vec3(1, 0, 0));
  }
  early.publishBias(100 * kMs, Vec3(3, 0, 0));
  EXPECT_EQ(early.take(100 * kMs, 150 * kMs).bias_radps, Vec3(2, 0, 0));
  EXPECT_EQ(late.take(100 * kMs, 150 * kMs).bias_radps, Vec3(2, 0, 0));
}

TEST(FrontendGyro, AnEstimatorStageFarBehindGivesTheNewestBiasItHasPublished) {
  FrontendGyro gyro;
  for (Timestamp t = 0; t <= 400 * kMs; t += 5 * kMs) gyro.add(sample(t));
  gyro.publishBias(0, Vec3(1, 0, 0));
  EXPECT_EQ(gyro.take(300 * kMs, 350 * kMs).bias_radps, Vec3(1, 0, 0));
  // Out-of-order publications are ignored.
  gyro.publishBias(400 * kMs, Vec3(4, 0, 0));
  gyro.publishBias(100 * kMs, Vec3(9, 0, 0));
  EXPECT_EQ(gyro.take(350 * kMs, 410 * kMs).bias_radps, Vec3(1, 0, 0));
}

TEST(FrontendGyro, TakeHandsOutTheSamplesAroundTheInterval) {
  FrontendGyro gyro;
  for (Timestamp t = 0; t <= 100 * kMs; t += 10 * kMs) gyro.add(sample(t));
  const auto w = gyro.take(25 * kMs, 55 * kMs);
  ASSERT_EQ(w.samples.size(), 5u);  // 20 (before 25) .. 60 (after 55)
  EXPECT_EQ(w.samples.front().t_ns, 20 * kMs);
  EXPECT_EQ(w.samples.back().t_ns, 60 * kMs);
}

}  // namespace
}  // namespace ovo::estimator
