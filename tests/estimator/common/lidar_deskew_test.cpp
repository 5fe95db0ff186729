// Deskewing a swept planar scan: a LiDAR turning and driving in a rectangular room, each beam
// ray-cast from where the LiDAR was at its own time, moved back to the scan's stamp.
#include "estimator/common/lidar_deskew.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace ovo::estimator {
namespace {

constexpr double kHalfX = 6.0, kHalfY = 4.0;  // walls at x = +-6 m, y = +-4 m

// Range from c along unit direction u (in the plane) to the room's walls.
double rayToWalls(const Vec2& c, const Vec2& u) {
  double t = std::numeric_limits<double>::infinity();
  if (u.x() > 1e-12) t = std::min(t, (kHalfX - c.x()) / u.x());
  if (u.x() < -1e-12) t = std::min(t, (-kHalfX - c.x()) / u.x());
  if (u.y() > 1e-12) t = std::min(t, (kHalfY - c.y()) / u.y());
  if (u.y() < -1e-12) t = std::min(t, (-kHalfY - c.y()) / u.y());
  return t;
}

SE3 planarPose(double yaw, const Vec3& p) {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
  T.translation() = p;
  return T;
}

struct Sweep {
  double yaw_rate = 0.35;           // rad/s: a headland turn's 20 deg/s
  Vec3 v_B = Vec3(0.8, 0.05, 0.0);  // m/s in the body frame at the stamp
  SE3 T_B_L = planarPose(0.1, Vec3(0.45, 0.0, 0.45));
  SE3 T_W_B0 = planarPose(0.3, Vec3(-1.0, 0.5, 0.0));

  Mat3 R_B0_B(double tau) const { return planarPose(yaw_rate * tau, Vec3::Zero()).linear(); }
  SE3 T_W_L(double tau) const {
    SE3 T_B0_B = planarPose(yaw_rate * tau, v_B * tau);
    return T_W_B0 * T_B0_B * T_B_L;
  }
  // The scan of a 10 Hz LiDAR: 541 beams over 270 deg, swept in 75 ms (or at once).
  LidarScan scan(bool swept) const {
    LidarScan s;
    s.t_ns = 1'000'000'000;
    s.angle_min_rad = -135.0 * M_PI / 180.0;
    s.angle_increment_rad = 0.5 * M_PI / 180.0;
    s.range_min_m = 0.1;
    s.range_max_m = 30.0;
    s.time_increment_s = swept ? 0.075 / 540.0 : 0.0;
    for (int i = 0; i < 541; ++i) {
      const SE3 T = T_W_L(swept ? i * s.time_increment_s : 0.0);
      const double a = s.angle_min_rad + i * s.angle_increment_rad;
      const Vec3 u = T.linear() * Vec3(std::cos(a), std::sin(a), 0.0);
      s.ranges_m.push_back(rayToWalls(T.translation().head<2>(), u.head<2>().normalized()));
    }
    return s;
  }
};

// Range errors (m) of `scan` against the instantaneous scan over the beams both have: median,
// 95th percentile and maximum.
struct Errors {
  double median = 1e9, p95 = 1e9, max = 1e9;
};
Errors rangeErrors(const LidarScan& scan, const LidarScan& truth) {
  std::vector<double> e;
  for (std::size_t i = 0; i < truth.ranges_m.size(); ++i)
    if (scan.valid(i) && truth.valid(i))
      e.push_back(std::abs(scan.ranges_m[i] - truth.ranges_m[i]));
  if (e.empty()) return {};
  std::sort(e.begin(), e.end());
  return {e[e.size() / 2], e[e.size() * 95 / 100], e.back()};
}

TEST(LidarDeskew, ASweptScanBecomesTheScanTakenAtItsStamp) {
  const Sweep sweep;
  const LidarScan swept = sweep.scan(true), truth = sweep.scan(false);
  const LidarMotion motion =
      lidarMotionFromBody([&](double tau) { return sweep.R_B0_B(tau); }, sweep.v_B, sweep.T_B_L);
  const LidarScan fixed = deskewScan(swept, motion);
  EXPECT_EQ(fixed.time_increment_s, 0.0);
  const Errors raw = rangeErrors(swept, truth), deskewed = rangeErrors(fixed, truth);
  RecordProperty("raw_p95_mm", std::to_string(raw.p95 * 1e3));
  RecordProperty("deskewed_median_mm", std::to_string(deskewed.median * 1e3));
  RecordProperty("deskewed_p95_mm", std::to_string(deskewed.p95 * 1e3));
  RecordProperty("deskewed_max_mm", std::to_string(deskewed.max * 1e3));
  EXPECT_GT(raw.p95, 0.05);  // the sweep moves the late beams' ends by up to 20 cm
  EXPECT_LT(deskewed.median, 0.001);
  EXPECT_LT(deskewed.p95, 0.003);
  // Where a wall is met at a grazing angle the range changes fast along the grid, and the
  // interpolation between two moved beams is off by up to ~1 cm.
  EXPECT_LT(deskewed.max, 0.03);
  int invalid = 0;
  for (std::size_t i = 0; i < fixed.ranges_m.size(); ++i) invalid += fixed.valid(i) ? 0 : 1;
  EXPECT_LE(invalid, 8);  // at most the grid's ends, where no moved beam reaches
}

// A spin on the spot at 90 deg/s moves the late beams by 13 increments: still resampled.
TEST(LidarDeskew, AFastSpinIsResampledToo) {
  Sweep sweep;
  sweep.yaw_rate = M_PI / 2.0;
  sweep.v_B = Vec3::Zero();
  const LidarScan swept = sweep.scan(true), truth = sweep.scan(false);
  const LidarScan fixed = deskewScan(
      swept,
      lidarMotionFromBody([&](double tau) { return sweep.R_B0_B(tau); }, sweep.v_B, sweep.T_B_L));
  const Errors deskewed = rangeErrors(fixed, truth);
  EXPECT_LT(deskewed.p95, 0.003);
  int invalid = 0;
  for (std::size_t i = 0; i < fixed.ranges_m.size(); ++i) invalid += fixed.valid(i) ? 0 : 1;
  EXPECT_LE(invalid, 16);  // the grid's far end, which the spin moved every beam away from
}

// The kf's deskew: the turn from raw gyro samples (200 Hz, with a bias the filter knows), no
// velocity. A turn on the spot about the body's origin: the LiDAR, 0.45 m ahead of it, still moves.
TEST(LidarDeskew, TheGyroAloneDeskewsATurnOnTheSpot) {
  Sweep sweep;
  sweep.v_B = Vec3::Zero();
  const LidarScan swept = sweep.scan(true), truth = sweep.scan(false);
  const Vec3 bias(0.01, -0.02, 0.005);
  std::vector<ImuSample> gyro;
  for (Timestamp t = swept.t_ns - 200'000'000; t <= swept.t_ns + 300'000'000; t += 5'000'000)
    gyro.push_back({t, Vec3(0.0, 0.0, sweep.yaw_rate) + bias, Vec3::Zero()});
  EXPECT_NEAR((meanSweepRate(swept, gyro, bias) - Vec3(0, 0, sweep.yaw_rate)).norm(), 0.0, 1e-12);
  const Errors raw = rangeErrors(swept, truth);
  const Errors fixed =
      rangeErrors(deskewScanWithGyro(swept, gyro, bias, Vec3::Zero(), sweep.T_B_L), truth);
  EXPECT_GT(raw.p95, 0.03);  // 20 deg/s for 75 ms, the lever arm included
  EXPECT_LT(fixed.median, 0.001);
  EXPECT_LT(fixed.p95, 0.003);
  // The bias left in would turn the scan by 0.5 mrad more at its end: still within a few mm.
  const Errors biased =
      rangeErrors(deskewScanWithGyro(swept, gyro, Vec3::Zero(), Vec3::Zero(), sweep.T_B_L), truth);
  EXPECT_GT(biased.median, fixed.median);
  // Samples that end before the sweep starts: the newest one's rate stands in.
  const std::vector<ImuSample> old(gyro.begin(), gyro.begin() + 10);
  EXPECT_NEAR((meanSweepRate(swept, old, bias) - Vec3(0, 0, sweep.yaw_rate)).norm(), 0.0, 1e-12);
  EXPECT_EQ(meanSweepRate(swept, {}, bias), Vec3::Zero());
  // Samples on both sides but none inside (a sparse gyro): the nearest one's, not the oldest's.
  std::vector<ImuSample> around = {{swept.t_ns - 500'000'000, Vec3(9, 9, 9), Vec3::Zero()},
                                   {swept.t_ns - 1'000'000, Vec3(0, 0, 1), Vec3::Zero()},
                                   {swept.t_ns + 200'000'000, Vec3(7, 7, 7), Vec3::Zero()}};
  EXPECT_EQ(meanSweepRate(swept, around, Vec3::Zero()), Vec3(0, 0, 1));
}

TEST(LidarDeskew, NoMotionOrNoBeamTimesLeavesTheScanAsItIs) {
  const Sweep sweep;
  const LidarScan swept = sweep.scan(true);
  const LidarScan still = deskewScan(swept, [](double) { return SE3(SE3::Identity()); });
  for (std::size_t i = 0; i < swept.ranges_m.size(); ++i)
    EXPECT_NEAR(still.ranges_m[i], swept.ranges_m[i], 1e-9) << i;
  LidarScan instant = sweep.scan(false);
  const LidarScan same = deskewScan(instant, [](double tau) {
    return planarPose(tau, Vec3::Zero());  // ignored: the scan has no beam times
  });
  EXPECT_EQ(same.ranges_m, instant.ranges_m);
}

TEST(LidarDeskew, AGapInTheScanStaysAGap) {
  const Sweep sweep;
  LidarScan swept = sweep.scan(true);
  for (int i = 200; i < 210; ++i) swept.ranges_m[i] = std::numeric_limits<double>::quiet_NaN();
  const LidarMotion motion =
      lidarMotionFromBody([&](double tau) { return sweep.R_B0_B(tau); }, sweep.v_B, sweep.T_B_L);
  const LidarScan fixed = deskewScan(swept, motion);
  int invalid_inside = 0;
  for (int i = 200; i < 210; ++i) invalid_inside += fixed.valid(i) ? 0 : 1;
  EXPECT_GE(invalid_inside, 8);  // the gap's edges may move by the sweep's rotation
}

}  // namespace
}  // namespace ovo::estimator
