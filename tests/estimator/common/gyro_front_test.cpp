// The gyro front every estimator takes its samples through (estimator/common/gyro_front.hpp): what
// it refuses and leaves out, its preintegration on the image clock, and the frontend stage's copy
// (FrontendGyro): the samples around an interval, without spikes, and which of the estimator
// stage's published biases the matching prior uses.
#include "estimator/common/gyro_front.hpp"

#include <gtest/gtest.h>

#include <limits>

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

// 200 Hz turning at 0.3 rad/s about z, with samples 10..12 clipped at 34.9 rad/s (a gyro's full
// scale).
std::vector<ImuSample> clippedTurn() {
  std::vector<ImuSample> out;
  for (int k = 0; k < 40; ++k) {
    ImuSample s;
    s.t_ns = k * 5 * kMs;
    s.gyro_radps = Vec3(0.0, 0.0, k >= 10 && k < 13 ? 34.9 : 0.3);
    out.push_back(s);
  }
  return out;
}

TEST(GyroFront, RefusesWhatIsNotAfterTheLastOrNotFiniteAndLeavesOutSpikes) {
  GyroFront gyro;
  int spikes = 0;
  for (const ImuSample& s : clippedTurn()) spikes += gyro.add(s) == GyroFront::Intake::kSpike;
  EXPECT_EQ(spikes, 3);
  EXPECT_EQ(gyro.spikes(), 3);
  EXPECT_EQ(gyro.samples().size(), 37u);
  for (const ImuSample& s : gyro.samples()) EXPECT_NEAR(s.gyro_radps.z(), 0.3, 1e-12);
  ImuSample late = gyro.samples().back();
  EXPECT_EQ(gyro.add(late), GyroFront::Intake::kInvalid);  // the same time again
  late.t_ns -= kMs;
  EXPECT_EQ(gyro.add(late), GyroFront::Intake::kInvalid);  // earlier
  late.t_ns += 10 * kMs;
  late.gyro_radps.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(gyro.add(late), GyroFront::Intake::kInvalid);
  // A refused sample is not the spike filter's reference: the next good one is taken.
  late.gyro_radps = Vec3(0.0, 0.0, 0.3);
  EXPECT_EQ(gyro.add(late), GyroFront::Intake::kAccepted);
}

TEST(GyroFront, IntegratesAnIntervalOfImageTimeOverTheGyroClocksShiftedInterval) {
  GyroFront gyro;
  for (int k = 0; k < 100; ++k) {
    ImuSample s;
    s.t_ns = k * 5 * kMs;
    s.gyro_radps = Vec3(0.0, 0.01 * k, 0.3);  // an angular acceleration: the shift shows
    gyro.add(s);
  }
  const Vec3 bias(0.001, 0.0, -0.002);
  const Timestamp shift = 12 * kMs;  // image stamps 12 ms ahead of the gyro clock
  const auto shifted = gyro.preintegrate(200 * kMs, 300 * kMs, bias, shift);
  const auto on_gyro_clock = gyro.preintegrate(188 * kMs, 288 * kMs, bias);
  ASSERT_TRUE(shifted && on_gyro_clock);
  EXPECT_TRUE(shifted->deltaR().isApprox(on_gyro_clock->deltaR(), 1e-15));
  EXPECT_FALSE(
      shifted->deltaR().isApprox(gyro.preintegrate(200 * kMs, 300 * kMs, bias)->deltaR(), 1e-6));
  EXPECT_FALSE(gyro.preintegrate(300 * kMs, 300 * kMs, bias));  // an empty interval
  EXPECT_FALSE(GyroFront().preintegrate(0, 100 * kMs, bias));   // no samples
}

// The matching prior sees the samples the estimator stage sees: a clipped reading left out.
TEST(FrontendGyro, LeavesOutSpikesAsTheEstimatorStageDoes) {
  FrontendGyro gyro(0);
  for (const ImuSample& s : clippedTurn()) gyro.add(s);
  const auto w = gyro.take(20 * kMs, 100 * kMs);
  ASSERT_FALSE(w.samples.empty());
  for (const ImuSample& s : w.samples) EXPECT_NEAR(s.gyro_radps.z(), 0.3, 1e-12) << s.t_ns;
}

}  // namespace
}  // namespace ovo::estimator
