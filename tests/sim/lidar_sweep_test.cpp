// Swept LiDAR scans: each beam cast from the pose of its own time.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/lidar.hpp"
#include "sim/simulation.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

bool sameRange(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

TEST(LidarSweep, BeamsOfATurningScannerHitAPostWhereTheTurnPutsThem) {
  // A level scanner 3 m beside a row's end post (bearing +90 deg), turning left at 90 deg/s
  // during a sweep of 0.1 s per turn: beam i points at angle_i + omega * i * dt in the world, so
  // the post shows at beam (90 deg - angle_min) / (increment + omega dt) instead of 450.
  WorldOptions w;
  w.num_rows = 1;
  w.leaf_density = 0.0;
  w.wire_radius_m = 0.0;
  w.backdrop = false;
  const VineyardWorld world(w, 1);
  LidarOptions o;
  o.noise = false;
  o.sweep = true;
  o.scan_time_s = 0.1;
  const double dt = o.timeIncrementS();
  ASSERT_DOUBLE_EQ(dt, 0.1 * 0.5 / 360.0);
  const double omega = 90.0 * kDeg;
  const auto pose = [&](double t) {
    SE3 T = SE3::Identity();
    T.linear() = Eigen::AngleAxisd(omega * t, Vec3::UnitZ()).toRotationMatrix();
    T.translation() = Vec3(0.0, -3.0, 1.2);
    return T;
  };
  const LidarScan swept = simulateSweptScan(world, pose, 0.0, 7, dt, o, 1);
  const LidarScan still = simulateScan(world, pose(0.0), 0.0, 7, o, 1);
  EXPECT_EQ(swept.t_ns, 7);
  EXPECT_EQ(swept.time_increment_s, dt);
  EXPECT_EQ(still.time_increment_s, 0.0);
  // The beam nearest the post's centre: the shortest range among beams near +90 deg.
  const auto nearest = [](const LidarScan& s) {
    int best = -1;
    for (int i = 350; i < 500; ++i)
      if (s.valid(i) && (best < 0 || s.ranges_m[i] < s.ranges_m[best])) best = i;
    return best;
  };
  const double r_post = 1.6 * w.post_radius_m;  // end posts are 1.6x thicker
  const int i_still = nearest(still), i_swept = nearest(swept);
  EXPECT_EQ(i_still, 450);
  EXPECT_NEAR(still.ranges_m[i_still], 3.0 - r_post, 1e-9);
  const double i_expected = (90.0 - o.angle_min_deg) / (o.angle_increment_deg + omega / kDeg * dt);
  EXPECT_NEAR(i_swept, i_expected, 1.0) << "expected about " << i_expected;
  EXPECT_LT(i_swept, i_still - 8);
  EXPECT_NEAR(swept.ranges_m[i_swept], 3.0 - r_post, 2e-3);
}

TEST(LidarSweep, EachBeamIsTheUnsweptBeamOfThePoseAtItsTime) {
  // During vineyard_row's headland U-turn (20 deg/s): beam i of the simulator's swept scan equals
  // beam i of an instantaneous scan from the pose at stamp + i * time_increment.
  Scenario s = test::exactScenario();
  s.lidar.sweep = true;
  s.camera.time_offset_s = 0.03;  // the LiDAR stays on the gyro clock
  const Simulation sim(s);
  const std::vector<LidarScan> scans = sim.lidar();
  const double dt = s.lidar.timeIncrementS();
  ASSERT_DOUBLE_EQ(dt, 0.1 * 0.5 / 360.0);  // one scan period per turn by default
  int checked = 0, moved = 0;
  for (std::size_t k = 0; k < scans.size(); k += 20) {
    const LidarScan& scan = scans[k];
    const int frame = static_cast<int>(k) * 2;  // 10 Hz on 20 Hz frames
    EXPECT_EQ(scan.t_ns, sim.frameTrueStamp(frame));
    EXPECT_EQ(scan.time_increment_s, dt);
    const double t0 = sim.frameTime(frame);
    const double yaw_rate = std::abs(
        (sim.trajectory().state(t0).T_W_B.linear() * sim.trajectory().state(t0).omega_B).z());
    if (yaw_rate < 10.0 * kDeg) continue;  // in the turn only
    const LidarScan at_t0 =
        simulateScan(sim.world(), sim.trajectory().T_W_B(t0) * sim.T_B_L(), t0, 0, s.lidar, 1);
    for (std::size_t i = 0; i < scan.ranges_m.size(); i += 7) {
      const double t = t0 + static_cast<double>(i) * dt;
      const LidarScan single =
          simulateScan(sim.world(), sim.trajectory().T_W_B(t) * sim.T_B_L(), t, 0, s.lidar, 1);
      EXPECT_TRUE(sameRange(scan.ranges_m[i], single.ranges_m[i])) << "scan " << k << " beam " << i;
      if (scan.valid(i) && at_t0.valid(i) && std::abs(scan.ranges_m[i] - at_t0.ranges_m[i]) > 0.05)
        ++moved;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
  EXPECT_GT(moved, 5);  // the sweep changes what the beams see in a turn
}

TEST(LidarSweep, OffByDefaultAndSweptScansNeedTheSweepSwitch) {
  const LidarOptions o;
  EXPECT_FALSE(o.sweep);
  EXPECT_EQ(o.timeIncrementS(), 0.0);
  LidarOptions on = o;
  on.sweep = true;
  EXPECT_DOUBLE_EQ(on.timeIncrementS(), 1.0 / o.rate_hz * o.angle_increment_deg / 360.0);
}

}  // namespace
}  // namespace ovo::sim
