// metrics.json of `ovo run` (DESIGN section 10): counts, accuracy against ground truth (keys
// absent without it) and timing. Shared by the offline and the online runner.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "common/stats.hpp"  // percentile(), used with the metrics
#include "estimator/estimator.hpp"
#include "eval/metrics.hpp"

namespace ovo::app {

/// The process's CPU and memory at one moment of a run (sampled about once a second).
struct ResourceSample {
  double wall_s = 0.0;  // since the run started
  int frames = 0;       // camera frames handed in so far
  double cpu_s = 0.0;   // CPU used by the run so far (user + system)
  double rss_mb = 0.0;  // resident memory now
};

struct RunTiming {
  std::vector<double> frontend_ms, estimator_ms, total_ms;
  std::vector<double>
      keyframe_ms;  // estimator_ms of the keyframes (their solve and marginalisation)
  std::vector<std::size_t> keyframe_frame;  // per keyframe_ms entry: its index in total_ms
  std::vector<ResourceSample> resources;    // over the run, in time order
  double cpu_s = -1.0;        // user + system CPU of the run, decoding included; < 0: not measured
  double peak_rss_mb = -1.0;  // peak resident memory of the process; < 0: not measured
  double sequence_s = 0.0;    // sensor time covered by the run
  double wall_s = 0.0;        // processing wall time
  // Online runs only (metrics gain latency_ms_median/_p99, frames_dropped, frames_in):
  std::optional<int> frames_dropped;  // camera frames the pipeline dropped when behind
  int frames_in = 0;                  // camera frames handed to the pipeline
  std::vector<double> latency_ms;     // per processed frame: handed in -> pose out
};

/// Builds the metrics object (with `segments`, KITTI's segment errors at 10-200 m, and
/// timing.trend, the cost at the start and at the end of the run). `groundtruth` may be empty.
/// min_move_m: the translation-direction error of frame i is measured to the first later frame that
/// truly moved at least this far (5 cm by default).
nlohmann::json computeRunMetrics(const Trajectory& estimate, const Trajectory& groundtruth,
                                 const estimator::EstimatorStats& stats, const RunTiming& timing,
                                 double min_move_m = 0.05);

/// The cost of the run's first tenth (after a warm-up of 5 % of the frames) and of its last
/// tenth: median frame and keyframe time, CPU per frame, median resident memory, and the ratio
/// last / first of each. A run that costs the same at its end as at its start has ratios near 1.
/// Null for runs of fewer than 200 frames.
nlohmann::json costTrend(const RunTiming& timing);

/// KITTI's segment errors as JSON (metrics.json's and `ovo eval`'s `segments`): one object a
/// length with length_m, count, trans_pct and rot_deg_per_100m. Json: nlohmann::json or
/// nlohmann::ordered_json.
template <typename Json>
Json segmentsJson(const std::vector<eval::SegmentError>& segments) {
  Json out = Json::array();
  for (const eval::SegmentError& s : segments)
    out.push_back({{"length_m", s.length_m},
                   {"count", s.count},
                   {"trans_pct", s.trans_pct},
                   {"rot_deg_per_100m", s.rot_deg_per_100m}});
  return out;
}

}  // namespace ovo::app
