// Feeds a dataset to an estimator in time order (gyro and scans before the image they precede),
// one thread, deterministic; collects per-frame estimates and timings.
#pragma once

#include <functional>
#include <vector>

#include "estimator/estimator.hpp"
#include "io/dataset.hpp"

namespace ovo::app {

struct OfflineRunResult {
  std::vector<estimator::FrameEstimate> frames;  // as returned by addImage
  double wall_s = 0.0;                           // whole run including image decoding
};

/// Progress callback: (frames done, frames total).
using ProgressFn = std::function<void(int, int)>;

/// Per-frame hook (e.g. the viewer): the estimate as returned by addImage and its image.
using FrameFn = std::function<void(const estimator::FrameEstimate&, const cv::Mat& grey)>;

/// Runs `est` over `data`; gyro samples up to and including the first one after each image time
/// are fed before the image (so preintegration can interpolate at the frame time). The stored
/// estimates keep no tracks (FrameEstimate::tracks, for viewers, goes to on_frame only).
OfflineRunResult runOffline(const io::Dataset& data, estimator::Estimator& est,
                            const ProgressFn& progress = {}, const FrameFn& on_frame = {});

/// The estimator's view of a dataset's sensors.
estimator::SensorSetup sensorSetupFrom(const io::Dataset& data);

}  // namespace ovo::app
