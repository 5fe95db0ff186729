#include "sim/lidar.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/simulation.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

WorldOptions emptyWorld() {
  WorldOptions w;
  w.num_rows = 0;
  w.backdrop = false;
  return w;
}

TEST(Lidar, NoiseFreeBeamsHitTheGroundPlaneAtTheGeometricRange) {
  WorldOptions w = emptyWorld();
  w.grade_pct = 10.0;
  const VineyardWorld world(w, 1);
  LidarOptions o;
  o.noise = false;
  o.range_max_m = 50.0;
  // LiDAR 0.8 m above the ground at x = 2, level, looking along +x (uphill); pitched down 10 deg.
  SE3 T_W_L = SE3::Identity();
  T_W_L.linear() = Eigen::AngleAxisd(10.0 * kDeg, Vec3::UnitY()).toRotationMatrix();
  T_W_L.translation() = Vec3(2.0, 0.0, world.groundHeight(2.0, 0.0) + 0.8);
  const LidarScan scan = simulateScan(world, T_W_L, 0.0, 0, o, 1);
  const int i0 =
      static_cast<int>(std::lround(-o.angle_min_deg / o.angle_increment_deg));  // angle 0
  ASSERT_NEAR(scan.angle(i0), 0.0, 1e-12);
  ASSERT_TRUE(scan.valid(i0));
  // Ray z = 0.8 - r sin(10deg) meets the ground z = 0.1 r cos(10deg) (relative to the start).
  const double r_expected = 0.8 / (std::sin(10.0 * kDeg) + 0.1 * std::cos(10.0 * kDeg));
  EXPECT_NEAR(scan.ranges_m[i0], r_expected, 1e-9);
  // Beams at +-90 deg stay level and the ground rises only along x: sideways there is no return.
  EXPECT_FALSE(scan.valid(i0 + static_cast<int>(std::lround(90.0 / o.angle_increment_deg))));
}

TEST(Lidar, NoiseFreeBeamHitsTheRowEndPostAtItsSurface) {
  WorldOptions w = emptyWorld();
  w.num_rows = 1;
  w.leaf_density = 0.0;
  w.wire_radius_m = 0.0;
  const VineyardWorld world(w, 1);
  LidarOptions o;
  o.noise = false;
  SE3 T_W_L = SE3::Identity();
  T_W_L.translation() = Vec3(-3.0, 0.0, 1.2);  // level, aimed along the row at its end post (x = 0)
  const LidarScan scan = simulateScan(world, T_W_L, 0.0, 0, o, 1);
  const int i0 = static_cast<int>(std::lround(-o.angle_min_deg / o.angle_increment_deg));
  ASSERT_TRUE(scan.valid(i0));
  EXPECT_NEAR(scan.ranges_m[i0], 3.0 - 1.6 * w.post_radius_m, 1e-9);  // end posts are 1.6x thicker
}

TEST(Lidar, BeamsPassThroughCanopyGaps) {
  WorldOptions w = emptyWorld();
  w.num_rows = 2;
  w.leaf_density = 0.5;
  const VineyardWorld world(w, 3);
  LidarOptions o;
  o.noise = false;
  o.range_max_m = 30.0;
  // Level scan at canopy height from the middle of the inter-row: beams crossing row 1 either stop
  // in its leaves (about 1.25 m away) or pass through a gap.
  SE3 T_W_L = SE3::Identity();
  T_W_L.translation() = Vec3(20.0, world.interrowY(0), 1.3);
  const LidarScan scan = simulateScan(world, T_W_L, 0.0, 0, o, 1);
  int in_leaves = 0, through = 0;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    const double a = scan.angle(i);
    if (a < 30.0 * kDeg || a > 150.0 * kDeg) continue;  // towards row 1 (+y)
    const double to_row = (world.rowY(1) - T_W_L.translation().y()) / std::sin(a);
    if (!scan.valid(i) || scan.ranges_m[i] > to_row + 0.3) {
      ++through;
    } else if (std::abs(scan.ranges_m[i] - to_row) < 0.3 / std::sin(a)) {
      ++in_leaves;
    }
  }
  EXPECT_GT(in_leaves, 20);
  EXPECT_GT(through, 5);
}

TEST(Lidar, MountTransformIsAppliedLidarToBody) {
  // Flat, empty world; robot standing: the forward beam of a LiDAR at height h pitched down by p
  // hits the ground at h / sin(p). With T_B_L inverted the LiDAR would sit below the body origin
  // and look upwards: no return.
  Scenario s = test::exactScenario();
  s.world = emptyWorld();
  s.trajectory.jitter = 0.0;
  s.frames = 3;
  const Simulation sim(s);
  const auto scans = sim.lidar();
  ASSERT_EQ(scans.size(), 2u);  // frames 0 and 2
  EXPECT_EQ(scans[0].t_ns, sim.frameStamp(0));
  EXPECT_EQ(scans[1].t_ns, sim.frameStamp(2));
  const LidarOptions& o = s.lidar;
  const int i0 = static_cast<int>(std::lround(-o.angle_min_deg / o.angle_increment_deg));
  const double h = s.trajectory.body_height_m + o.mount.z_m;
  ASSERT_TRUE(scans[0].valid(i0));
  EXPECT_NEAR(scans[0].ranges_m[i0], h / std::sin(o.mount.pitch_down_deg * kDeg), 1e-9);
}

}  // namespace
}  // namespace ovo::sim
