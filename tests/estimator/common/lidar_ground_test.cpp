// The camera height measured from a pitched LiDAR's ground hits (cameraHeightFromLidar): the
// window tests' synthetic vineyard scans (flat ground, canopy slabs on both sides from 0.5 m up)
// with the simulator's rig: body 0.3 m above the ground, LiDAR 0.45 m above the body pitched 8
// degrees down, camera 0.7 m above the body (a camera height of 1.0 m); and the simulator's own
// scans of every scenario against its camera height.
#include "estimator/common/lidar_ground.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "common/config.hpp"
#include "sim/simulation.hpp"
#include "tests/estimator/window/synthetic.hpp"
#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

constexpr double kBodyHeight = 0.3;

SE3 lidarInBody(double pitch_down_deg) {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(pitch_down_deg * M_PI / 180.0, Vec3::UnitY()).toRotationMatrix();
  T.translation() = Vec3(0.45, 0.0, 0.45);
  return T;
}

SE3 cameraInBody() {
  SE3 T = SE3::Identity();
  T.translation() = Vec3(0.35, 0.0, 0.7);
  return T;
}

// The synthetic vineyard's scan (window_synthetic.hpp) by a LiDAR at T_B_L on a body standing
// kBodyHeight above the ground.
LidarScan castScan(const SE3& T_B_L, double range_max_m, std::mt19937& rng) {
  SE3 T_W_B = SE3::Identity();
  T_W_B.translation().z() = kBodyHeight;
  std::normal_distribution<double> gauss(0.0, 1.0);
  return test::castSyntheticScan(T_W_B * T_B_L, 0, rng, gauss, range_max_m);
}

std::vector<LidarScan> castScans(const SE3& T_B_L, double range_max_m, int n = 20) {
  std::mt19937 rng(5);
  std::vector<LidarScan> scans;
  for (int k = 0; k < n; ++k) scans.push_back(castScan(T_B_L, range_max_m, rng));
  return scans;
}

TEST(LidarGround, APitchedLidarMeasuresTheCameraHeight) {
  const SE3 T_B_L = lidarInBody(8.0);
  const auto scans = castScans(T_B_L, 12.0);
  const auto one = bodyHeightFromScan(scans.front(), T_B_L);
  ASSERT_TRUE(one.has_value());
  EXPECT_NEAR(*one, kBodyHeight, 0.01);
  const auto h = cameraHeightFromLidar(scans, T_B_L, cameraInBody());
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->camera_height_m, 1.0, 0.005);
  EXPECT_EQ(h->scans_agreeing, 20);
  EXPECT_EQ(h->scans_used, 20);
  EXPECT_EQ(h->scans_seen, 20);
  // Only the first max_scans are looked at.
  LidarGroundOptions first;
  first.max_scans = 6;
  EXPECT_EQ(cameraHeightFromLidar(scans, T_B_L, cameraInBody(), first)->scans_seen, 6);
}

TEST(LidarGround, ALevelLidarOrOneThatDoesNotReachTheGroundGivesNothing) {
  // Level: every end point lies at the LiDAR's own height.
  const SE3 level = lidarInBody(0.0);
  EXPECT_FALSE(bodyHeightFromScan(castScans(level, 12.0, 1).front(), level).has_value());
  EXPECT_FALSE(cameraHeightFromLidar(castScans(level, 12.0), level, cameraInBody()).has_value());
  // Pitched, but the ground is 5.3 m ahead and the range ends at 4 m: only the walls, whose end
  // points fall along the scan (no height band).
  const SE3 pitched = lidarInBody(8.0);
  EXPECT_FALSE(cameraHeightFromLidar(castScans(pitched, 4.0), pitched, cameraInBody()).has_value());
}

// Scans whose body height is that of the rig plus `shift(k)` for scan k.
std::vector<LidarScan> shiftedScans(const SE3& T_B_L, const std::function<double(int)>& shift) {
  std::vector<LidarScan> scans;
  for (int k = 0; k < 30; ++k) {
    SE3 T = T_B_L;
    T.translation().z() += shift(k);
    std::mt19937 rng(static_cast<unsigned>(k));
    scans.push_back(castScan(T, 12.0, rng));
  }
  return scans;
}

TEST(LidarGround, TheScansThatAgreeGiveTheHeight) {
  // Standing for 10 scans, then driving over rough ground: the ground ahead is 4-10 cm above or
  // below the plane the robot stands on (steep_slope's scans scatter by +-7 cm). The standing
  // scans agree.
  const SE3 T_B_L = lidarInBody(8.0);
  const auto scans = shiftedScans(T_B_L, [](int k) {
    return k < 10 ? 0.0 : (k % 2 == 0 ? 1.0 : -1.0) * (0.04 + 0.03 * (k % 3));
  });
  const auto h = cameraHeightFromLidar(scans, T_B_L, cameraInBody());
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->camera_height_m, 1.0, 0.005);
  EXPECT_EQ(h->scans_agreeing, 10);
  EXPECT_EQ(h->scans_used, 30);
}

TEST(LidarGround, TooFewScansOrScatteredHeightsGiveNothing) {
  const SE3 T_B_L = lidarInBody(8.0);
  EXPECT_FALSE(cameraHeightFromLidar(castScans(T_B_L, 12.0, 4), T_B_L, cameraInBody()).has_value());
  // Every scan's ground at its own height (3 cm apart, at most 3 scans within 2 cm): no group
  // of 5 agrees.
  const auto scattered = shiftedScans(T_B_L, [](int k) { return 0.03 * (k % 10); });
  EXPECT_FALSE(cameraHeightFromLidar(scattered, T_B_L, cameraInBody()).has_value());
}

// The simulator's scans (its terrain, canopy, posts and range noise; steep_slope drives on a rough
// 20 % slope) in the first 8 s of each scenario: measured 0.998-1.003 m against 1.000 m.
TEST(LidarGround, TheSimulatorsScansGiveItsCameraHeight) {
  for (const char* scenario : {"vineyard_row", "headland_turn", "steep_slope", "standstill",
                               "pure_rotation", "vineyard_row_pinhole"}) {
    SCOPED_TRACE(scenario);
    Config cfg = Config::load(test::sourcePath(std::string("configs/sim/") + scenario + ".yaml"));
    cfg.applyOverrides({"duration_s=8"});
    const sim::Simulation sim(sim::readScenario(cfg));
    const auto h = cameraHeightFromLidar(sim.lidar(), sim.T_B_L(), sim.T_B_C());
    ASSERT_TRUE(h.has_value());
    EXPECT_NEAR(h->camera_height_m, sim.cameraHeightM(), 0.005);
    EXPECT_GE(h->scans_agreeing, 10);
  }
}

// The spread of the ground beams about their line across the scan (groundRoughnessFromScan) on the
// simulator's vineyard_row with its terrain's height standard deviation set
// (world.ground_roughness_m, over 2 m) and its LiDAR's range noise (2 cm). Flat, the spread is the
// range noise's share (measured 2.5 mm against 2.6 mm) and terrainRoughness says 0. Rough, it is
// the terrain's: measured 13.9 mm at 1.5 cm and 20.3 mm at 3 cm, where the scans whose ground
// hides behind bumps (40 % of them) give nothing and the rest are the smoother ones; the bounds
// leave 0.13-0.18 of the truth of margin below those.
TEST(LidarGround, TheGroundBeamsSpreadIsTheTerrainsRoughness) {
  const std::vector<std::pair<double, double>> roughness_and_least = {
      {0.0, 0.0}, {0.015, 0.75 * 0.015}, {0.03, 0.55 * 0.03}};
  double previous = -1.0;
  for (const auto& [roughness, least] : roughness_and_least) {
    SCOPED_TRACE(roughness);
    Config cfg = Config::load(test::sourcePath("configs/sim/vineyard_row.yaml"));
    cfg.applyOverrides({"duration_s=15", fmt::format("world.ground_roughness_m={}", roughness),
                        "world.ground_wavelength_m=2.0"});
    const sim::Simulation sim(sim::readScenario(cfg));
    std::deque<GroundRoughness> measured;
    for (const LidarScan& scan : sim.lidar())
      if (const auto r = groundRoughnessFromScan(scan, sim.T_B_L(), 0.02)) {
        EXPECT_GE(r->points, LidarGroundOptions{}.min_points);
        EXPECT_GT(r->noise_m, 0.0);
        measured.push_back(*r);
      }
    ASSERT_GE(measured.size(), 0.4 * sim.lidar().size());
    const auto terrain = terrainRoughness(measured, 10);
    ASSERT_TRUE(terrain.has_value());
    RecordProperty(fmt::format("terrain_mm_at_{}", roughness), std::to_string(1000 * *terrain));
    if (roughness == 0.0) {
      EXPECT_LT(*terrain, 0.002) << "the range noise is the flat ground's whole spread";
    } else {
      EXPECT_GE(*terrain, least);
      EXPECT_LE(*terrain, 1.2 * roughness);
      EXPECT_GT(*terrain, previous + 0.005) << "rougher ground must read rougher";
    }
    previous = *terrain;
  }
}

// A LiDAR 4 m short of the ground beside one wall (the plane y = 1 m + slope x of the body, from
// the ground up 2 m; slope 0.5: a row of vines seen 27 deg off as the robot turns), with 2 cm of
// range noise: its low end points run along the wall, ahead.
LidarScan oneWallScan(const SE3& T_B_L, double slope) {
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss(0.0, 0.02);
  LidarScan scan;
  scan.angle_min_rad = -135.0 * M_PI / 180.0;
  scan.angle_increment_rad = 0.5 * M_PI / 180.0;
  scan.range_min_m = 0.1;
  scan.range_max_m = 4.0;
  for (int i = 0; i <= 540; ++i) {
    const double angle = scan.angle_min_rad + i * scan.angle_increment_rad;
    const Vec3 o = T_B_L.translation();
    const Vec3 d = T_B_L.linear() * Vec3(std::cos(angle), std::sin(angle), 0.0);
    double range = std::numeric_limits<double>::quiet_NaN();
    if (d.y() - slope * d.x() > 1e-9) {
      const double t = (1.0 - o.y() + slope * o.x()) / (d.y() - slope * d.x());
      const double z = o.z() + t * d.z();
      if (t <= scan.range_max_m && z >= -kBodyHeight && z <= 2.0 - kBodyHeight)
        range = t + gauss(rng);
    }
    scan.ranges_m.push_back(range);
  }
  return scan;
}

TEST(LidarGround, NoRoughnessWithoutGroundOrFromTooFewScans) {
  // Level: every end point at the LiDAR's own height. Pitched with a 4 m range: walls only.
  const SE3 level = lidarInBody(0.0), pitched = lidarInBody(8.0);
  EXPECT_FALSE(groundRoughnessFromScan(castScans(level, 12.0, 1).front(), level, 0.02));
  EXPECT_FALSE(groundRoughnessFromScan(castScans(pitched, 4.0, 1).front(), pitched, 0.02));
  // One wall: its end points below the LiDAR run along the body, not across it. Along the body
  // (slope 0) they fit no line across it; slanted, they do, but spread more ahead than across.
  EXPECT_FALSE(groundRoughnessFromScan(oneWallScan(pitched, 0.0), pitched, 0.02));
  EXPECT_FALSE(groundRoughnessFromScan(oneWallScan(pitched, 0.5), pitched, 0.02));
  const auto one = groundRoughnessFromScan(castScans(pitched, 12.0, 1).front(), pitched, 0.02);
  ASSERT_TRUE(one.has_value());
  // Flat ground: the spread is the range noise's share, 2 cm times the beams' up component (the
  // LiDAR's pitch, 8 deg, less across the scan).
  EXPECT_NEAR(one->spread_m, one->noise_m, 0.5 * one->noise_m);
  EXPECT_NEAR(one->noise_m, 0.02 * std::sin(8.0 * M_PI / 180.0), 0.0005);
  const std::deque<GroundRoughness> few(9, *one);
  EXPECT_FALSE(terrainRoughness(few, 10).has_value());
  EXPECT_FALSE(terrainRoughness({}, 0).has_value());
}

}  // namespace
}  // namespace ovo::estimator
