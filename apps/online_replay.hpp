// `ovo run --realtime`: replays a recorded dataset at sensor rate (optionally scaled) into the
// OnlinePipeline from a replay thread that sleeps until each measurement's time, so the
// estimator sees what it would see live: frames dropped when it falls behind, real latency.
#pragma once

#include <algorithm>
#include <functional>
#include <vector>

#include "apps/offline_runner.hpp"
#include "apps/online_pipeline.hpp"
#include "io/dataset.hpp"

namespace ovo::app {

struct RealtimeOptions {
  double rate = 1.0;  // replay speed: 2 replays twice as fast as recorded
  OnlineOptions pipeline;
  io::RecordPolicy records;  // strict: an image that cannot be used is an error (else skipped)
};

struct RealtimeRunResult {
  std::vector<estimator::FrameEstimate> frames;  // processed frames in order (tracks cleared)
  OnlineStats stats;
  double wall_s = 0.0;             // first measurement handed in -> pipeline stopped
  double replay_lag_ms_max = 0.0;  // worst lateness of an image hand-over (decoding, scheduling)
  io::SkippedRecords skipped;      // images skipped (loadImageOrSkip)
};

/// The sensor times the replay clock runs over: from the first camera frame to the last (without
/// frames, the first to the last measurement of any sensor). Measurements outside it are handed
/// over at once, before the first frame or after the last: a stray early or late stamp (a
/// driver's first gyro sample stamped 0 in an epoch-stamped recording) would otherwise make the
/// replay sleep for the whole gap, decades.
struct ReplaySpan {
  Timestamp begin_ns = 0, end_ns = 0;
  Timestamp clamp(Timestamp t_ns) const { return std::clamp(t_ns, begin_ns, end_ns); }
};
ReplaySpan replaySpan(const io::Dataset& data);

/// Replays `data` into an OnlinePipeline driving `est` on the calling thread (the replay thread;
/// the pipeline adds its frontend and estimator threads). on_output runs on the estimator thread
/// for every processed frame (e.g. the viewer); progress gets (frames handed in, total). An image
/// that cannot be used is skipped as in runOffline (its time passes without a frame).
RealtimeRunResult runRealtime(const io::Dataset& data, estimator::Estimator& est,
                              const RealtimeOptions& options,
                              const OnlinePipeline::OutputCallback& on_output = {},
                              const ProgressFn& progress = {});

}  // namespace ovo::app
