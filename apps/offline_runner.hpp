// Feeds a dataset to an estimator in time order (gyro and scans before the image they precede),
// deterministic, and collects per-frame estimates and timings. By default images are decoded on a
// thread of their own, a few ahead, and the frontend stage (Estimator::track) runs on a second
// thread, up to estimator::kFrontendLeadFrames images ahead of the estimator stage
// (Estimator::update), so it goes on through a keyframe's solve; track(k) starts only after
// update(k-1-lead) is done, so the poses are exactly those of the stages run in sequence (the
// frontend's gyro prior uses the bias published after frame k-1-lead, estimator::FrontendGyro).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "estimator/estimator.hpp"
#include "io/dataset.hpp"

namespace ovo::app {

struct OfflineRunResult {
  std::vector<estimator::FrameEstimate> frames;  // as returned by update()
  double wall_s = 0.0;                           // whole run including image decoding
};

struct OfflineOptions {
  bool pipelined = true;  // frontend and estimator stages on two threads (same poses)
};

/// Progress callback: (frames done, frames total).
using ProgressFn = std::function<void(int, int)>;

/// Per-frame hook (e.g. the viewer): the estimate as returned by update() and its image.
using FrameFn = std::function<void(const estimator::FrameEstimate&, const cv::Mat& grey)>;

/// Runs `est` over `data`; gyro samples up to and including the first one after each image time
/// are fed before the image (so preintegration can interpolate at the frame time). The stored
/// estimates keep no tracks (FrameEstimate::tracks, for viewers, goes to on_frame only).
/// Callbacks run on the calling thread. An exception from either stage (a corrupt image, ...)
/// stops both and is rethrown here.
OfflineRunResult runOffline(const io::Dataset& data, estimator::Estimator& est,
                            const ProgressFn& progress = {}, const FrameFn& on_frame = {},
                            const OfflineOptions& options = {});

/// The estimator's view of a dataset's sensors.
estimator::SensorSetup sensorSetupFrom(const io::Dataset& data);

/// When the rig gives no camera height and the LiDAR's first scans show the ground
/// (estimator::cameraHeightFromLidar), sets setup->camera_height_m from them and returns a note
/// saying so; nullopt (setup unchanged) otherwise.
std::optional<std::string> cameraHeightFromScans(const io::Dataset& data,
                                                 estimator::SensorSetup* setup);

}  // namespace ovo::app
