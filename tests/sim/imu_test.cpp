#include "sim/imu.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "common/so3.hpp"
#include "sim/trajectory.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

TEST(Imu, NoiseFreeGyroIntegratedOverTenSecondsMatchesTheTrueRotation) {
  Scenario s = test::exactScenario();
  s.world.grade_pct = 15.0;
  s.world.side_tilt_pct = 5.0;
  const VineyardWorld world(s.world, s.seed);
  const BodyTrajectory traj = planTrajectory(s.trajectory, world, s.seed);
  const auto imu = simulateImu(traj, s.imu, traj.duration(), 0, s.seed);
  // Ten seconds through the headland U-turn, with ride vibration on every axis.
  const int k0 = static_cast<int>(14.0 * s.imu.rate_hz),
            k1 = static_cast<int>(24.0 * s.imu.rate_hz);
  Mat3 R = Mat3::Identity();
  for (int k = k0; k < k1; ++k) {
    const double dt = (imu[k + 1].t_ns - imu[k].t_ns) * 1e-9;
    R = R * so3::exp(0.5 * (imu[k].gyro_radps + imu[k + 1].gyro_radps) * dt);
  }
  const Mat3 R_true = traj.T_W_B(imu[k0].t_ns * 1e-9).linear().transpose() *
                      traj.T_W_B(imu[k1].t_ns * 1e-9).linear();
  EXPECT_GT(so3::angle(R_true), 2.5);  // the U-turn is in the window
  EXPECT_LT(so3::angle(R.transpose() * R_true) * 180.0 / M_PI, 0.01);
}

TEST(Imu, AccelerometerReadsGravityWhileStanding) {
  Scenario s = test::exactScenario();
  s.world.grade_pct = 30.0;
  s.trajectory.jitter = 0.0;  // heading exactly up the grade
  const VineyardWorld world(s.world, s.seed);
  const BodyTrajectory traj = planTrajectory(s.trajectory, world, s.seed);
  const auto imu = simulateImu(traj, s.imu, 1.0, 0, s.seed);
  const Vec3 f = imu[20].accel_mps2;  // t = 0.1 s, standing on a 30 % grade
  EXPECT_NEAR(f.norm(), 9.81, 1e-9);
  // Specific force points straight up; the nose points uphill, so it has a forward component.
  EXPECT_NEAR(std::atan2(f.x(), f.z()), std::atan(0.30), 1e-6);
  EXPECT_NEAR(f.y(), 0.0, 1e-9);
  EXPECT_NEAR(imu[20].gyro_radps.norm(), 0.0, 1e-12);
}

TEST(Imu, NoiseAndBiasHaveTheConfiguredStatistics) {
  const Scenario s = test::defaultScenario();
  const VineyardWorld world(s.world, s.seed);
  const BodyTrajectory traj = planTrajectory(s.trajectory, world, s.seed);
  std::vector<GyroBiasSample> bias;
  const auto imu = simulateImu(traj, s.imu, traj.duration(), 0, s.seed, &bias);
  ASSERT_EQ(bias.size(), imu.size());
  double sum2 = 0.0;
  for (std::size_t k = 0; k < imu.size(); ++k) {
    const Vec3 n = imu[k].gyro_radps - traj.state(imu[k].t_ns * 1e-9).omega_B - bias[k].bias_radps;
    sum2 += n.squaredNorm();
  }
  const double sigma = std::sqrt(sum2 / (3.0 * imu.size()));
  EXPECT_NEAR(sigma, s.imu.gyro_noise_density * std::sqrt(s.imu.rate_hz), 0.05 * sigma);
  // The bias drifts as a random walk: over T seconds its change is ~ walk * sqrt(T) per axis.
  const double T = traj.duration();
  const Vec3 drift = bias.back().bias_radps - bias.front().bias_radps;
  EXPECT_LT(drift.cwiseAbs().maxCoeff(), 5.0 * s.imu.gyro_bias_random_walk * std::sqrt(T));
  EXPECT_GT(bias.front().bias_radps.norm(), 1e-4);  // an initial bias of a few tenths of deg/s
  EXPECT_LT(bias.front().bias_radps.norm(), 0.06);
}

}  // namespace
}  // namespace ovo::sim
