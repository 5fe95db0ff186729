#include "apps/offline_runner.hpp"

#include <spdlog/spdlog.h>

#include <chrono>

#include "common/error.hpp"

namespace ovo::app {

estimator::SensorSetup sensorSetupFrom(const io::Dataset& data) {
  if (!data.camera) fail("{}: the dataset has no camera calibration", data.root.string());
  estimator::SensorSetup s{.camera = *data.camera};
  s.T_B_C = data.rig.T_B_C;
  s.T_B_L = data.rig.T_B_L;
  s.camera_rate_hz = data.rig.camera_rate_hz;
  s.pixel_sigma = data.rig.pixel_sigma;
  s.camera_height_m = data.rig.camera_height_m;
  s.gyro_noise_density = data.rig.gyro_noise_density;
  s.gyro_bias_random_walk = data.rig.gyro_bias_random_walk;
  s.lidar_range_sigma_m = data.rig.lidar_range_sigma_m;
  s.has_gyro = !data.imu.empty();
  s.has_lidar = !data.scans.empty();
  return s;
}

OfflineRunResult runOffline(const io::Dataset& data, estimator::Estimator& est,
                            const ProgressFn& progress, const FrameFn& on_frame) {
  OfflineRunResult result;
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t next_imu = 0, next_scan = 0;
  const int total = static_cast<int>(data.images.size());
  for (int i = 0; i < total; ++i) {
    const auto& entry = data.images[i];
    estimator::feedUntilImage(entry.t_ns, data.imu, next_imu, data.scans, next_scan, est);

    const cv::Mat grey = io::loadImageGrey(entry);  // a corrupt image is an error naming the file
    result.frames.push_back(est.addImage(entry.t_ns, grey));
    if (on_frame) on_frame(result.frames.back(), grey);
    result.frames.back().tracks.clear();
    if (progress) progress(i + 1, total);
  }
  while (next_imu < data.imu.size()) est.addGyro(data.imu[next_imu++]);
  est.finish();
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace ovo::app
