// Wind: leaf clusters sway smoothly by at most the amplitude; trunks, posts and wires stay put.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/lidar.hpp"
#include "sim/world.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

WorldOptions windy(double amplitude_m, double period_s) {
  WorldOptions w;
  w.num_rows = 2;
  w.backdrop = false;
  w.wind_amplitude_m = amplitude_m;
  w.wind_period_s = period_s;
  return w;
}

TEST(Wind, LeavesSwayByAtMostTheAmplitudeAndSmoothlyInTime) {
  const double A = 0.04, period = 2.0;
  const VineyardWorld world(windy(A, period), 3);
  double max_disp = 0.0, max_rate = 0.0;
  const double dt = 1e-3;
  for (int row = 0; row < 2; ++row)
    for (int layer = 0; layer < 3; ++layer)
      for (double x = 0.0; x < 40.0; x += 1.37)
        for (double h = 0.6; h < 1.9; h += 0.23)
          for (double t = 0.0; t < 6.0; t += 0.29) {
            const Vec2 d = world.leafSway(row, layer, x, h, t);
            max_disp = std::max(max_disp, d.norm());
            const Vec2 d2 = world.leafSway(row, layer, x, h, t + dt);
            max_rate = std::max(max_rate, (d2 - d).norm() / dt);
          }
  EXPECT_LE(max_disp, A);
  EXPECT_GT(max_disp, 0.5 * A);  // they do move, by a good part of the amplitude
  // Smooth: no faster than the fastest of its sines allows (2.11 / period cycles a second).
  EXPECT_LE(max_rate, A * 2.11 * 2.0 * M_PI / period);
  EXPECT_GT(max_rate, 0.1 * A * 2.0 * M_PI / period);
  // Clusters a metre apart sway differently.
  EXPECT_GT((world.leafSway(0, 0, 10.0, 1.2, 1.0) - world.leafSway(0, 0, 11.0, 1.2, 1.0)).norm(),
            0.05 * A);
  // No wind: no sway.
  const VineyardWorld calm(windy(0.0, period), 3);
  EXPECT_EQ(calm.leafSway(0, 1, 10.0, 1.2, 1.0), Vec2::Zero());
}

// Level scan at canopy height from the middle of the inter-row at time t.
LidarScan canopyScan(const VineyardWorld& world, double t) {
  LidarOptions o;
  o.noise = false;
  o.range_max_m = 30.0;
  SE3 T_W_L = SE3::Identity();
  T_W_L.translation() = Vec3(20.0, world.interrowY(0), 1.3);
  return simulateScan(world, T_W_L, t, 0, o, 1);
}

TEST(Wind, LeavesMoveUnderTheLidarWhilePostsStayPut) {
  const VineyardWorld world(windy(0.05, 2.0), 5), calm(windy(0.0, 2.0), 5);
  const LidarScan a = canopyScan(world, 0.0), b = canopyScan(world, 0.7);
  const LidarScan c = canopyScan(calm, 0.0), d = canopyScan(calm, 0.7);
  int leaves = 0, changed = 0;
  for (std::size_t i = 0; i < a.ranges_m.size(); ++i) {
    EXPECT_TRUE(c.ranges_m[i] == d.ranges_m[i] ||
                (std::isnan(c.ranges_m[i]) && std::isnan(d.ranges_m[i])));
    if (!a.valid(i) || a.ranges_m[i] > 3.0) continue;  // the leaves of the two rows beside
    ++leaves;
    if (!b.valid(i) || std::abs(a.ranges_m[i] - b.ranges_m[i]) > 0.01) ++changed;
  }
  EXPECT_GT(leaves, 100);
  EXPECT_GT(changed, leaves / 10);
  // The row-end post, seen along the row from outside it, at any time.
  WorldOptions w = windy(0.05, 2.0);
  w.num_rows = 1;
  const VineyardWorld one(w, 5);
  LidarOptions o;
  o.noise = false;
  SE3 T_W_L = SE3::Identity();
  T_W_L.translation() = Vec3(-3.0, 0.0, 1.2);
  const int i0 = static_cast<int>(std::lround(-o.angle_min_deg / o.angle_increment_deg));
  for (double t : {0.0, 0.4, 1.1, 2.5}) {
    const LidarScan s = simulateScan(one, T_W_L, t, 0, o, 1);
    ASSERT_TRUE(s.valid(i0));
    EXPECT_NEAR(s.ranges_m[i0], 3.0 - 1.6 * w.post_radius_m, 1e-9) << t;
  }
}

TEST(Wind, TrunksStayPut) {
  // Level beams through the trunk zone below the canopy see the same at any time of a windy day.
  WorldOptions w = windy(0.05, 2.0);
  w.leaf_density = 0.9;
  const VineyardWorld world(w, 8);
  LidarOptions o;
  o.noise = false;
  SE3 T_W_L = SE3::Identity();
  T_W_L.translation() = Vec3(20.0, world.interrowY(0), 0.3);  // trunks reach 0.7 m, leaves 0.55
  const LidarScan a = simulateScan(world, T_W_L, 0.0, 0, o, 1);
  const LidarScan b = simulateScan(world, T_W_L, 1.3, 0, o, 1);
  int trunks = 0;
  for (std::size_t i = 0; i < a.ranges_m.size(); ++i) {
    EXPECT_TRUE(a.ranges_m[i] == b.ranges_m[i] ||
                (std::isnan(a.ranges_m[i]) && std::isnan(b.ranges_m[i])))
        << i;
    if (a.valid(i) && a.ranges_m[i] < 2.0) ++trunks;
  }
  EXPECT_GT(trunks, 3);  // it does see trunks
}

}  // namespace
}  // namespace ovo::sim
