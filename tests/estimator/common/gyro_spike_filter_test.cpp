// GyroSpikeFilter: short jumps of the rate are left out, lasting ones and smooth motion are kept.
#include "estimator/common/gyro_spike_filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace ovo::estimator {
namespace {

ImuSample sample(int k, double rate_z) {
  ImuSample s;
  s.t_ns = static_cast<Timestamp>(k) * 5'000'000;  // 200 Hz
  s.gyro_radps = Vec3(0.01, -0.02, rate_z);
  return s;
}

TEST(GyroSpikeFilter, ThreeSamplesAtFullScaleAreLeftOut) {
  GyroSpikeFilter f(10.0, 0.05);
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(f.accept(sample(k, 0.3)));
  for (int k = 10; k < 13; ++k) EXPECT_FALSE(f.accept(sample(k, 34.9))) << k;
  for (int k = 13; k < 20; ++k) EXPECT_TRUE(f.accept(sample(k, 0.3))) << k;
  EXPECT_EQ(f.rejected(), 3);
}

TEST(GyroSpikeFilter, AJumpThatLastsIsTakenAsRealAfterTheSpikeTime) {
  GyroSpikeFilter f(10.0, 0.05);
  EXPECT_TRUE(f.accept(sample(0, 0.0)));
  int rejected = 0;
  for (int k = 1; k < 40; ++k) rejected += !f.accept(sample(k, 12.0));
  // 50 ms at 200 Hz: the first 11 samples (0 to 50 ms after the jump) are left out, then kept.
  EXPECT_EQ(rejected, 11);
}

TEST(GyroSpikeFilter, ASpikeAtStartUpIsLeftOutAndTheRatesAfterItKept) {
  // Before, the first sample was the reference whatever it was: the spike was kept and the next
  // 50 ms of true rates left out as jumps from it.
  GyroSpikeFilter f(10.0, 0.05);
  EXPECT_FALSE(f.accept(sample(0, 34.9)));
  for (int k = 1; k < 20; ++k) EXPECT_TRUE(f.accept(sample(k, 0.3))) << k;
  EXPECT_EQ(f.rejected(), 1);
}

TEST(GyroSpikeFilter, ASaturationLongerThanTheSpikeTimeIsKeptAndSoIsTheReturnFromIt) {
  // 150 ms at full scale (a knock): the first 50 ms are left out, the rest is taken as real, and
  // the return to the rate before it is kept at once (before, it was a jump and left out for
  // another 50 ms).
  GyroSpikeFilter f(10.0, 0.05);
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(f.accept(sample(k, 0.3)));
  int rejected = 0;
  for (int k = 10; k < 40; ++k) rejected += !f.accept(sample(k, 34.9));
  EXPECT_EQ(rejected, 11);
  for (int k = 40; k < 60; ++k) EXPECT_TRUE(f.accept(sample(k, 0.3))) << k;
  // A spike after that is a spike again.
  EXPECT_FALSE(f.accept(sample(60, 34.9)));
  EXPECT_TRUE(f.accept(sample(61, 0.3)));
}

TEST(GyroSpikeFilter, ADropoutInALastingFastTurnDoesNotCostTheTurnAfterIt) {
  // A pivot at 12 rad/s taken as real after 50 ms; then one sample reads 0 (a dropout): it passes
  // as the return to the rate before the pivot, and the pivot's rate after it is a return too.
  GyroSpikeFilter f(10.0, 0.05);
  EXPECT_TRUE(f.accept(sample(0, 0.0)));
  for (int k = 1; k < 40; ++k) f.accept(sample(k, 12.0));
  EXPECT_TRUE(f.accept(sample(40, 0.0)));
  for (int k = 41; k < 50; ++k) EXPECT_TRUE(f.accept(sample(k, 12.0))) << k;
}

TEST(GyroSpikeFilter, FastSmoothTurnsAndNoFilterKeepEverySample) {
  GyroSpikeFilter f(10.0, 0.05);
  for (int k = 0; k < 400; ++k)  // up to 6 rad/s and back, 2 s
    EXPECT_TRUE(f.accept(sample(k, 6.0 * std::sin(M_PI * k / 400.0)))) << k;
  GyroSpikeFilter off(0.0, 0.05);
  EXPECT_TRUE(off.accept(sample(0, 0.0)));
  EXPECT_TRUE(off.accept(sample(1, 34.9)));
}

TEST(GyroSpikeFilter, ANonFiniteRateIsLeftOut) {
  GyroSpikeFilter f(10.0, 0.05);
  EXPECT_TRUE(f.accept(sample(0, 0.1)));
  EXPECT_FALSE(f.accept(sample(1, std::numeric_limits<double>::quiet_NaN())));
  EXPECT_TRUE(f.accept(sample(2, 0.1)));
}

}  // namespace
}  // namespace ovo::estimator
