// The configuration files in configs/ document the keys with the values built in: each loads
// with no unknown key, and reads back as the default options (a default changed in the code but
// not in the file, or a key renamed, fails here).
#include <gtest/gtest.h>

#include "common/config.hpp"
#include "estimator/common/ground_plane.hpp"
#include "estimator/kf/estimator.hpp"
#include "estimator/vo/chain.hpp"
#include "estimator/vo/estimator.hpp"
#include "estimator/window/options.hpp"
#include "frontend/frontend.hpp"
#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

// A rig with SensorSetup's default noise figures (the camera does not matter here).
SensorSetup defaultRig() { return {camera::PinholeRadtanCamera(300, 300, 320, 240, 640, 480)}; }

TEST(ConfigFiles, FrontendYamlHoldsTheBuiltInDefaults) {
  const Config cfg = Config::load(test::sourcePath("configs/frontend.yaml"));
  EXPECT_TRUE(frontend::readFrontendOptions(cfg) == frontend::FrontendOptions{});
  EXPECT_TRUE(frontend::readFrontendOptions(cfg).relative_pose == frontend::RelativePoseOptions{});
  EXPECT_TRUE(frontend::readFrontendOptions(cfg).track_refine == frontend::TrackRefineOptions{});
  EXPECT_NO_THROW(cfg.checkAllUsed());
}

TEST(ConfigFiles, VoYamlHoldsTheBuiltInDefaults) {
  const Config cfg = Config::load(test::sourcePath("configs/estimator/vo.yaml"));
  EXPECT_TRUE(readVoChainOptions(cfg) == VoChainOptions{});
  EXPECT_TRUE(readVoOptions(cfg) == VoOptions{});
  EXPECT_NO_THROW(cfg.checkAllUsed());
}

TEST(ConfigFiles, WindowYamlHoldsTheBuiltInDefaults) {
  const Config cfg = Config::load(test::sourcePath("configs/estimator/window.yaml"));
  EXPECT_TRUE(readWindowOptions(cfg) == WindowOptions{});
  EXPECT_NO_THROW(cfg.checkAllUsed());
}

TEST(ConfigFiles, KfYamlHoldsTheBuiltInDefaults) {
  // The filter's gyro noise figures come from the rig, not from kf.yaml.
  const Config cfg = Config::load(test::sourcePath("configs/estimator/kf.yaml"));
  EXPECT_TRUE(readKfEstimatorOptions(cfg, defaultRig()) == KfEstimatorOptions{});
  EXPECT_NO_THROW(cfg.checkAllUsed());
}

TEST(ConfigFiles, AChangedValueIsSeen) {
  // The comparison is not vacuous: one key off its default differs.
  Config cfg = Config::load(test::sourcePath("configs/frontend.yaml"));
  cfg.applyOverride("frontend.track_refine_min_gradient=3.0");
  EXPECT_FALSE(frontend::readFrontendOptions(cfg) == frontend::FrontendOptions{});
  Config window = Config::load(test::sourcePath("configs/estimator/window.yaml"));
  window.applyOverride("window.ground_scale_gate_no_lidar=0.4");
  EXPECT_FALSE(readWindowOptions(window) == WindowOptions{});
  for (const char* key :
       {"kf.vo_sigma0_rad=2e-4", "kf.lidar_scale.edge_relative=0.1", "kf.scale_walk=0.003"}) {
    Config kf = Config::load(test::sourcePath("configs/estimator/kf.yaml"));
    kf.applyOverride(key);
    EXPECT_FALSE(readKfEstimatorOptions(kf, defaultRig()) == KfEstimatorOptions{}) << key;
  }
}

}  // namespace
}  // namespace ovo::estimator
