// The estimator factory's helpers (estimator/estimator.hpp).
#include "estimator/estimator.hpp"

#include <gtest/gtest.h>

#include "common/config.hpp"
#include "estimator/kf_estimator.hpp"
#include "estimator/window_options.hpp"

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

}  // namespace
}  // namespace ovo::estimator
