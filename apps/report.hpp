// report.html of `ovo run`: one self-contained page (inline CSS, plots as inline SVG, no script,
// no external reference) with the top view of estimate and ground truth (SE(3)-aligned for
// display), position and yaw error over time, position, heading and scale error against the
// distance driven, the gyro bias estimate against the truth when known, per-frame timing, CPU
// and memory over the run, the metrics table and the configuration used.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "apps/run_metrics.hpp"
#include "common/types.hpp"

namespace ovo::app {

/// Per processed frame: stage times and, in online runs, the latency (negative: none).
struct FrameTiming {
  Timestamp t_ns = 0;
  double frontend_ms = 0.0, estimator_ms = 0.0;
  double latency_ms = -1.0;
  bool keyframe = false;  // estimator_ms holds the keyframe's solve and marginalisation
};

struct ReportInputs {
  std::string estimator;             // "window", "kf", "vo"
  std::string dataset;               // folder
  std::string mode;                  // "offline" or "realtime"
  Trajectory estimate, groundtruth;  // T_W_B; ground truth may be empty
  std::vector<std::pair<Timestamp, Vec3>> bias_estimate, bias_truth;  // [rad/s]; may be empty
  std::vector<FrameTiming> timing;
  std::vector<ResourceSample> resources;  // CPU and memory over the run; may be empty
  nlohmann::json metrics;   // metrics.json's object
  std::string config_yaml;  // the configuration used (Config::dump())
};

/// The page as text (UTF-8 HTML5).
std::string renderReportHtml(const ReportInputs& inputs);
/// Writes renderReportHtml() to `file`; throws ovo::Error naming the file when it cannot.
void writeReport(const std::filesystem::path& file, const ReportInputs& inputs);

}  // namespace ovo::app
