// metrics.json of `ovo run` (DESIGN section 10): counts, accuracy against ground truth (keys
// absent without it) and timing. Shared by the offline and the online runner.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "estimator/estimator.hpp"

namespace ovo::app {

struct RunTiming {
  std::vector<double> frontend_ms, estimator_ms, total_ms;
  std::vector<double>
      keyframe_ms;            // estimator_ms of the keyframes (their solve and marginalisation)
  double cpu_s = -1.0;        // user + system CPU of the run, decoding included; < 0: not measured
  double peak_rss_mb = -1.0;  // peak resident memory of the process; < 0: not measured
  double sequence_s = 0.0;    // sensor time covered by the run
  double wall_s = 0.0;        // processing wall time
  // Online runs only (metrics gain latency_ms_median/_p99, frames_dropped, frames_in):
  std::optional<int> frames_dropped;  // camera frames the pipeline dropped when behind
  int frames_in = 0;                  // camera frames handed to the pipeline
  std::vector<double> latency_ms;     // per processed frame: handed in -> pose out
};

/// Builds the metrics object. `groundtruth` may be empty. min_move_m: the translation-direction
/// error of frame i is measured to the first later frame that truly moved at least this far
/// (5 cm by default).
nlohmann::json computeRunMetrics(const Trajectory& estimate, const Trajectory& groundtruth,
                                 const estimator::EstimatorStats& stats, const RunTiming& timing,
                                 double min_move_m = 0.05);

/// Percentile (0..100) of a sample, linear interpolation; 0 for an empty sample.
double percentile(std::vector<double> values, double pct);

}  // namespace ovo::app
