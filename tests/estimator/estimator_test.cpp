// The estimator factory's helpers (estimator/estimator.hpp).
#include "estimator/estimator.hpp"

#include <gtest/gtest.h>

#include "common/config.hpp"
#include "common/error.hpp"
#include "estimator/kf/estimator.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {
namespace {

TEST(EstimatorUsesLidar, FollowsEachEstimatorsOwnSwitch) {
  const SensorSetup rig{camera::PinholeRadtanCamera(300, 300, 320, 240, 640, 480)};
  for (const char* text : {"{}", "kf: {use_lidar: false}", "window: {use_lidar: false}",
                           "kf: {use_lidar: false}\nwindow: {use_lidar: false}"}) {
    SCOPED_TRACE(text);
    const Config cfg = Config::fromString(text);
    // The same answer as the options each estimator reads for itself.
    EXPECT_EQ(estimatorUsesLidar("kf", cfg), readKfEstimatorOptions(cfg, rig).use_lidar);
    EXPECT_EQ(estimatorUsesLidar("window", cfg), readWindowOptions(cfg).use_lidar);
    EXPECT_FALSE(estimatorUsesLidar("vo", cfg));  // the plain camera chain has no LiDAR
    EXPECT_FALSE(estimatorUsesLidar("nonesuch", cfg));
  }
  EXPECT_TRUE(estimatorUsesLidar("window", Config::fromString("kf: {use_lidar: false}")));
  EXPECT_FALSE(estimatorUsesLidar("window", Config::fromString("window: {use_lidar: false}")));
  EXPECT_TRUE(estimatorUsesLidar("kf", Config::fromString("window: {use_lidar: false}")));
}

// Two models of the camera's height at once (one for the run and one along the path) are refused
// with both keys named; either alone reads.
TEST(WindowOptionsRead, RefusesTwoModelsOfTheCameraHeight) {
  try {
    readWindowOptions(Config::fromString(
        "window: {camera_height_path: true, estimate_camera_height: true}"));
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("window.camera_height_path"), std::string::npos) << what;
    EXPECT_NE(what.find("window.estimate_camera_height"), std::string::npos) << what;
  }
  EXPECT_TRUE(readWindowOptions(Config::fromString("window: {camera_height_path: true}"))
                  .camera_height_path);
  EXPECT_TRUE(readWindowOptions(Config::fromString("window: {estimate_camera_height: true}"))
                  .estimate_camera_height);
}

// A noise-free simulation writes 0 for its noise figures; the estimators' factors would weigh
// them infinitely (Ceres: NaN residuals, "Terminating"). They are raised to floors, each with a
// note; real figures pass unchanged.
TEST(ApplyNoiseFloors, RaisesZerosAndKeepsRealFigures) {
  SensorSetup rig{camera::PinholeRadtanCamera(300, 300, 320, 240, 640, 480)};
  const SensorSetup real = rig;
  EXPECT_TRUE(applyNoiseFloors(rig).empty());
  EXPECT_EQ(rig.pixel_sigma, real.pixel_sigma);
  EXPECT_EQ(rig.gyro_noise_density, real.gyro_noise_density);
  EXPECT_EQ(rig.gyro_bias_random_walk, real.gyro_bias_random_walk);
  EXPECT_EQ(rig.lidar_range_sigma_m, real.lidar_range_sigma_m);

  rig.pixel_sigma = rig.gyro_noise_density = rig.gyro_bias_random_walk = 0.0;
  rig.lidar_range_sigma_m = 0.0;
  const auto notes = applyNoiseFloors(rig);
  ASSERT_EQ(notes.size(), 4u);
  EXPECT_NE(notes[1].find("gyro.noise_density 0 rad/s/sqrt(Hz)"), std::string::npos) << notes[1];
  EXPECT_DOUBLE_EQ(rig.pixel_sigma, 0.05);
  EXPECT_DOUBLE_EQ(rig.gyro_noise_density, 1e-6);
  EXPECT_DOUBLE_EQ(rig.gyro_bias_random_walk, 1e-7);
  EXPECT_DOUBLE_EQ(rig.lidar_range_sigma_m, 1e-3);
  EXPECT_TRUE(applyNoiseFloors(rig).empty());  // at the floor: nothing more to raise
}

// trimHistory keeps every entry from keep_from on, and drops the older ones in batches: never
// more than as many old entries as kept ones, so a history fed one entry a step stays bounded.
TEST(TrimHistory, KeepsTheRecentPartAndDropsTheRestInBatches) {
  std::vector<Timestamp> h;
  std::size_t most = 0;
  for (Timestamp t = 0; t < 1000; ++t) {
    h.push_back(t);
    trimHistory(h, t - 99, [](Timestamp x) { return x; });  // keep the last 100
    most = std::max(most, h.size());
    ASSERT_GE(h.size(), std::min<std::size_t>(t + 1, 100));
    ASSERT_EQ(h.back(), t);
    ASSERT_LE(static_cast<Timestamp>(h.size()) - 1, std::max<Timestamp>(t - h.front(), 0));
  }
  EXPECT_LE(most, 200u);
  EXPECT_GE(h.front(), 1000 - 200);
  EXPECT_LE(h.front(), 1000 - 100);
  std::vector<Timestamp> all = {1, 2, 3};
  trimHistory(all, 0, [](Timestamp x) { return x; });
  EXPECT_EQ(all.size(), 3u);  // nothing older than keep_from
}

}  // namespace
}  // namespace ovo::estimator
