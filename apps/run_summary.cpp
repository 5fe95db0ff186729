#include "apps/run_summary.hpp"

#include <fmt/format.h>

namespace ovo::app {

namespace {

template <typename T>
bool get(const nlohmann::json& j, const char* key, T* value) {
  if (!j.contains(key) || j[key].is_null()) return false;
  *value = j[key].get<T>();
  return true;
}

}  // namespace

std::string runSummary(const nlohmann::json& m, const std::string& estimator,
                       const std::string& dataset, const std::filesystem::path& out) {
  std::string s;
  int frames = 0, tracked = 0;
  get(m, "frames", &frames);
  get(m, "frames_tracked", &tracked);
  double length = 0.0;
  get(m, "length_m", &length);
  s += fmt::format("ovo run: {} on {}: {} frames ({} tracked), path {:.1f} m\n", estimator, dataset,
                   frames, tracked, length);
  double ate = 0, ate_pct = 0, yaw = 0, scale = 0;
  if (get(m, "ate_rmse_m", &ate)) {
    get(m, "ate_pct", &ate_pct);
    std::string line = fmt::format("  ATE {:.1f} mm ({:.3f} % of the path)", ate * 1000.0, ate_pct);
    if (get(m, "final_yaw_err_deg", &yaw)) line += fmt::format(", final yaw error {:.2f} deg", yaw);
    if (get(m, "scale_err_pct", &scale)) line += fmt::format(", scale error {:+.2f} %", scale);
    s += line + "\n";
  } else {
    s += "  no ground truth: accuracy not measured (give --gt FILE)\n";
  }
  if (m.contains("timing")) {
    double rtf = 0, frame_ms = 0;
    get(m["timing"], "realtime_factor", &rtf);
    get(m["timing"], "total_ms_median", &frame_ms);
    std::string line =
        fmt::format("  speed: {:.2f}x realtime ({:.1f} ms a frame, median", rtf, frame_ms);
    double kf_p90 = 0, cpu = 0, rss = 0;
    if (get(m["timing"], "keyframe_ms_p90", &kf_p90))
      line += fmt::format("; keyframes {:.1f} ms p90", kf_p90);
    line += ")";
    if (get(m["timing"], "cpu_s", &cpu)) line += fmt::format(", {:.1f} s of CPU", cpu);
    if (get(m["timing"], "peak_rss_mb", &rss)) line += fmt::format(", peak memory {:.0f} MiB", rss);
    s += line + "\n";
  }
  if (out.empty())
    s += "  nothing written (give --out DIR for the trajectory, metrics.json and report.html)\n";
  else
    s += fmt::format("  report: {} (trajectory.txt, metrics.json beside it)\n",
                     (out / "report.html").string());
  return s;
}

}  // namespace ovo::app
