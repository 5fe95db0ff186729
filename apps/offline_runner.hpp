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
  io::SkippedRecords skipped;                    // images skipped (missing, corrupt, wrong size)
};

struct OfflineOptions {
  bool pipelined = true;     // frontend and estimator stages on two threads (same poses)
  io::RecordPolicy records;  // strict: an image that cannot be used is an error (else skipped)
};

/// Progress callback: (frames done, frames total).
using ProgressFn = std::function<void(int, int)>;

/// Per-frame hook (e.g. the viewer): the estimate as returned by update() and its image.
using FrameFn = std::function<void(const estimator::FrameEstimate&, const cv::Mat& grey)>;

/// Runs `est` over `data`; gyro samples up to and including the first one after each image time
/// are fed before the image (so preintegration can interpolate at the frame time). The stored
/// estimates keep no tracks (FrameEstimate::tracks, for viewers, goes to on_frame only).
/// Callbacks run on the calling thread. An image that cannot be used (missing, truncated,
/// corrupt, of another size than the calibration's) is skipped, counted in result.skipped and
/// warned about once per kind (loadImageOrSkip), unless options.records.strict; a run left without
/// any usable image is an error. An exception from either stage stops both and is rethrown here.
OfflineRunResult runOffline(const io::Dataset& data, estimator::Estimator& est,
                            const ProgressFn& progress = {}, const FrameFn& on_frame = {},
                            const OfflineOptions& options = {});

/// Image `index` of `data` (io::loadDatasetImage), or nullopt when it cannot be used and the policy
/// skips it: then it is counted in `skipped`, and the first of each kind is logged as a warning.
/// Strict: the io::RecordError is thrown.
std::optional<cv::Mat> loadImageOrSkip(const io::Dataset& data, std::size_t index,
                                       const io::RecordPolicy& policy, io::SkippedRecords& skipped);

/// Logs the warning for a kind of skipped record: its count, reason and first record; with
/// more_may_follow (a run going on), that the rest of its kind are skipped quietly.
void warnSkipped(const io::SkippedRecords::Kind& kind, bool more_may_follow = false);

/// The error for a run in which no image could be used (names the first one's problem).
[[noreturn]] void failNoUsableImage(const io::Dataset& data, const io::SkippedRecords& skipped);

/// The estimator's view of a rig's sensors (extrinsics T_B_L, rates, noise figures, camera
/// height, time offset, rolling shutter) for `camera` at T_B_C; gyro and LiDAR present. The
/// time offset is the caller's to apply to the image stamps (imagesOntoGyroClock, or each image
/// online): no estimator moves them.
estimator::SensorSetup sensorSetupFromRig(const io::RigInfo& rig, const camera::Camera& camera,
                                          const SE3& T_B_C);
/// The estimator's view of a dataset's sensors.
estimator::SensorSetup sensorSetupFrom(const io::Dataset& data);

/// Moves the image stamps onto the gyro clock by the rig's camera.time_offset_s (image stamp =
/// gyro-clock time + offset; the LiDAR and the ground truth are on the gyro clock), so that every
/// estimator pairs each image with the gyro and the scans of its true time; the rig's offset is
/// then 0 (the stamps hold it). Returns the note that says so, none when the offset is 0. Call it
/// once, before sensorSetupFrom.
std::optional<std::string> imagesOntoGyroClock(io::Dataset& data);

/// When the rig gives no camera height and the LiDAR's first scans show the ground
/// (estimator::cameraHeightFromLidar), sets setup->camera_height_m from them and returns a note
/// saying so; nullopt (setup unchanged) otherwise.
std::optional<std::string> cameraHeightFromScans(const io::Dataset& data,
                                                 estimator::SensorSetup* setup);

}  // namespace ovo::app
