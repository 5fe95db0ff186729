// Fuzz target for the estimator configuration (--config): parsed, its first line also tried as a
// --set override, then read by every module's options reader.
#include <string>

#include "common/config.hpp"
#include "estimator/common/ground_plane.hpp"
#include "estimator/kf/filter.hpp"
#include "estimator/common/lidar_scale.hpp"
#include "estimator/vo/chain.hpp"
#include "estimator/window/options.hpp"
#include "factors/gyro_preintegration.hpp"
#include "frontend/frontend.hpp"
#include "frontend/relative_pose.hpp"
#include "tests/fuzz/fuzz_target.hpp"

OVO_FUZZ_TARGET(config_yaml) {
  const std::string text(reinterpret_cast<const char*>(input.data()), input.size());
  ovo::fuzz::expectOnlyOvoErrors([&] {
    ovo::Config config = ovo::Config::fromString(text, "fuzz.yaml");
    const std::string first_line = text.substr(0, text.find('\n'));
    ovo::fuzz::expectOnlyOvoErrors([&] { config.applyOverride(first_line); });
    (void)ovo::frontend::readFrontendOptions(config);
    (void)ovo::frontend::readRelativePoseOptions(config);
    (void)ovo::estimator::readWindowOptions(config);
    (void)ovo::estimator::readKfOptions(config);
    (void)ovo::estimator::readVoChainOptions(config);
    (void)ovo::estimator::readGroundPlaneOptions(config);
    (void)ovo::estimator::readLidarScaleOptions(config);
    (void)ovo::factors::readGyroPreintegrationOptions(config);
    (void)config.dump();
    config.checkAllUsed();
  });
}
