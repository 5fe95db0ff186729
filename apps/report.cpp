#include "apps/report.hpp"

#include <fmt/format.h>

#include <cmath>
#include <fstream>

#include "apps/svg_plot.hpp"
#include "common/error.hpp"
#include "eval/metrics.hpp"
#include "io/text_reader.hpp"

namespace ovo::app {
namespace {

constexpr const char* kStyle = R"(
body { font-family: "DejaVu Sans", Arial, sans-serif; margin: 24px; color: #222; background: #f6f6f4; }
h1 { font-size: 22px; margin: 0 0 4px 0; }
h2 { font-size: 17px; margin: 28px 0 8px 0; border-bottom: 1px solid #ccc; padding-bottom: 4px; }
.sub { color: #666; margin-bottom: 16px; }
.tiles { display: flex; flex-wrap: wrap; gap: 12px; }
.tile { background: #fff; border: 1px solid #ddd; border-radius: 6px; padding: 10px 14px; min-width: 140px; }
.tile .v { font-size: 20px; font-weight: bold; }
.tile .k { color: #666; font-size: 12px; }
.plots { display: flex; flex-wrap: wrap; gap: 12px; align-items: flex-start; }
.plots svg { background: #fff; border: 1px solid #ddd; border-radius: 4px; }
.col { display: flex; flex-direction: column; gap: 12px; }
table { border-collapse: collapse; background: #fff; font-size: 13px; }
td, th { border: 1px solid #ddd; padding: 3px 10px; text-align: left; }
td.n { text-align: right; font-family: "DejaVu Sans Mono", monospace; }
pre { background: #fff; border: 1px solid #ddd; padding: 10px; font-size: 12px; overflow-x: auto; }
.note { color: #666; font-size: 13px; }
)";

std::string formatValue(const nlohmann::json& v) {
  if (v.is_number_float()) {
    const double d = v.get<double>();
    return std::isfinite(d) ? fmt::format("{:.4g}", d) : "n/a";
  }
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

void flatten(const nlohmann::json& j, const std::string& prefix,
             std::vector<std::pair<std::string, std::string>>& rows) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (it->is_object()) {
      flatten(*it, key, rows);
    } else if (it->is_array()) {
      std::string joined;
      for (const auto& e : *it) joined += (joined.empty() ? "" : "; ") + formatValue(e);
      rows.push_back({key, joined.empty() ? "(none)" : joined});
    } else {
      rows.push_back({key, formatValue(*it)});
    }
  }
}

std::string tile(const nlohmann::json& m, const std::string& key, const std::string& label,
                 const std::string& unit) {
  if (!m.contains(key) || !m[key].is_number()) return "";
  return fmt::format(
      "<div class=\"tile\"><div class=\"v\">{} {}</div><div class=\"k\">{}</div></div>\n",
      xmlEscape(formatValue(m[key])), xmlEscape(unit), xmlEscape(label));
}

std::string biasPlot(const ReportInputs& in) {
  if (in.bias_estimate.empty() && in.bias_truth.empty()) return "";
  const Timestamp t0 = !in.estimate.empty()        ? in.estimate.front().t_ns
                       : !in.bias_estimate.empty() ? in.bias_estimate.front().first
                                                   : in.bias_truth.front().first;
  const char* colours[3] = {"#d62728", "#2ca02c", "#1f77b4"};
  const char* axes[3] = {"x", "y", "z"};
  constexpr double kDegPerRad = 180.0 / M_PI;
  std::vector<PlotSeries> series;
  for (int k = 0; k < 3; ++k) {
    PlotSeries est{fmt::format("b_g {} estimate", axes[k]), {}, {}, colours[k]};
    for (const auto& [t, b] : in.bias_estimate) {
      est.x.push_back(toSeconds(t - t0));
      est.y.push_back(b(k) * kDegPerRad);
    }
    PlotSeries truth{fmt::format("b_g {} true", axes[k]), {}, {}, colours[k], true, 1.2};
    for (const auto& [t, b] : in.bias_truth) {
      const double ts = toSeconds(t - t0);
      if (!in.estimate.empty() && (t < in.estimate.front().t_ns || t > in.estimate.back().t_ns))
        continue;  // the run's time span only
      truth.x.push_back(ts);
      truth.y.push_back(b(k) * kDegPerRad);
    }
    if (!est.x.empty()) series.push_back(std::move(est));
    if (!truth.x.empty()) series.push_back(std::move(truth));
  }
  PlotOptions o;
  o.title = in.bias_estimate.empty()
                ? "Gyro bias (true; not estimated by this estimator)"
                : "Gyro bias estimate" + std::string(in.bias_truth.empty() ? "" : " vs truth");
  o.x_label = "time [s]";
  o.y_label = "bias [deg/s]";
  o.width_px = 640;
  o.height_px = 300;
  return svgLinePlot(series, o);
}

std::string timingPlot(const ReportInputs& in) {
  if (in.timing.empty()) return "";
  const Timestamp t0 = in.timing.front().t_ns;
  PlotSeries fe{"frontend", {}, {}, "#1b9e77"}, es{"estimator", {}, {}, "#d95f02"},
      total{"total", {}, {}, "#555555", false, 1.0}, lat{"latency (online)", {}, {}, "#7570b3"},
      kf{"keyframe (solve + marginalisation)", {}, {}, "#e7298a", false, 1.6, 2.5};
  for (const auto& f : in.timing) {
    const double t = toSeconds(f.t_ns - t0);
    fe.x.push_back(t), fe.y.push_back(f.frontend_ms);
    es.x.push_back(t), es.y.push_back(f.estimator_ms);
    total.x.push_back(t), total.y.push_back(f.frontend_ms + f.estimator_ms);
    if (f.latency_ms >= 0) lat.x.push_back(t), lat.y.push_back(f.latency_ms);
    if (f.keyframe) kf.x.push_back(t), kf.y.push_back(f.estimator_ms);
  }
  std::vector<PlotSeries> series{total, fe, es};
  if (!kf.x.empty()) series.push_back(kf);
  if (!lat.x.empty()) series.push_back(lat);
  PlotOptions o;
  o.title = "Per-frame timing";
  o.y_include_zero = true;
  o.x_label = "time [s]";
  o.y_label = "[ms]";
  o.width_px = 640;
  o.height_px = 300;
  return svgLinePlot(series, o);
}

// CPU per frame between samples and the resident memory, against the run's wall time.
std::string resourcePlot(const ReportInputs& in) {
  if (in.resources.size() < 2) return "";
  PlotSeries cpu{"CPU per frame handed in", {}, {}, "#1b9e77"};
  PlotSeries rss{"resident memory", {}, {}, "#7570b3"};
  for (std::size_t k = 0; k < in.resources.size(); ++k) {
    const ResourceSample& r = in.resources[k];
    if (r.rss_mb >= 0.0) rss.x.push_back(r.wall_s), rss.y.push_back(r.rss_mb);
    if (k == 0) continue;
    const ResourceSample& q = in.resources[k - 1];
    if (r.frames > q.frames)
      cpu.x.push_back(r.wall_s), cpu.y.push_back(1e3 * (r.cpu_s - q.cpu_s) / (r.frames - q.frames));
  }
  PlotOptions o;
  o.y_include_zero = true;
  o.x_label = "wall time [s]";
  o.width_px = 640;
  o.height_px = 260;
  o.title = "CPU per frame (user + system, all threads)";
  o.y_label = "[ms]";
  std::string s = svgLinePlot({cpu}, o);
  if (!rss.x.empty()) {
    o.title = "Resident memory";
    o.y_label = "[MiB]";
    s += svgLinePlot({rss}, o);
  }
  return s;
}

}  // namespace

std::string renderReportHtml(const ReportInputs& in) {
  const nlohmann::json& m = in.metrics;
  std::string h;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  h += fmt::format("<title>ovo run: {} on {}</title>\n", xmlEscape(in.estimator),
                   xmlEscape(in.dataset));
  h += fmt::format("<style>{}</style>\n</head>\n<body>\n", kStyle);
  h += fmt::format("<h1>ovo run: <code>{}</code></h1>\n", xmlEscape(in.estimator));
  h += fmt::format(
      "<div class=\"sub\">dataset <code>{}</code> &middot; {} &middot; {} poses{}</div>\n",
      xmlEscape(in.dataset), xmlEscape(in.mode), in.estimate.size(),
      in.groundtruth.empty() ? " &middot; no ground truth" : "");

  h += "<div class=\"tiles\">\n";
  h += tile(m, "ate_rmse_m", "ATE RMSE (SE(3))", "m");
  h += tile(m, "ate_pct", "ATE / path length", "%");
  h += tile(m, "drift_pct", "drift", "%");
  h += tile(m, "final_yaw_err_deg", "final yaw error", "deg");
  h += tile(m, "scale_err_pct", "scale error", "%");
  h += tile(m, "length_m", "path length", "m");
  h += tile(m, "frames_tracked", "frames tracked", "of " + formatValue(m.value("frames", 0)));
  h += tile(m, "latency_ms_median", "latency median", "ms");
  h += tile(m, "latency_ms_p99", "latency p99", "ms");
  h += tile(m, "frames_dropped", "frames dropped", "");
  if (m.contains("time_offset_s") && m["time_offset_s"].is_number()) {
    const nlohmann::json ms = {{"v", 1e3 * m["time_offset_s"].get<double>()}};
    h += tile(ms, "v",
              m.value("time_offset_estimated", false) ? "camera-gyro time offset (estimated)"
                                                      : "camera-gyro time offset (rig.yaml)",
              "ms");
  }
  if (m.contains("timing")) {
    const nlohmann::json& t = m["timing"];
    h += tile(t, "realtime_factor", "realtime factor", "x");
    h += tile(t, "keyframe_ms_p90", "keyframe solve p90", "ms");
    h += tile(t, "cpu_s", "CPU (user + system)", "s");
    h += tile(t, "peak_rss_mb", "peak resident memory", "MiB");
  }
  h += "</div>\n";

  h += "<h2>Trajectory</h2>\n<div class=\"plots\">\n";
  const auto cmp =
      in.groundtruth.empty() ? std::nullopt : compareTrajectories(in.groundtruth, in.estimate);
  if (cmp) {
    h += svgTopView(*cmp, "Top view: estimate and ground truth");
    h += "<div class=\"col\">\n" + svgErrorsOverTime(*cmp) + "</div>\n";
  } else {
    h += svgTopViewSingle(in.estimate, "Top view: estimate");
  }
  h += "</div>\n";
  if (!in.groundtruth.empty() && !cmp)
    h += "<p class=\"note\">Fewer than 3 poses match the ground truth in time (0.02 s): no "
         "error plots.</p>\n";
  if (cmp)
    h += fmt::format(
        "<p class=\"note\">The estimate is {}-aligned onto the ground truth for display; yaw "
        "error is the heading error about the top view's up axis.</p>\n",
        cmp->alignment == "SE(3)" ? "SE(3) (Umeyama)" : "first-pose (SE(3) alignment degenerate)");

  if (!in.groundtruth.empty()) {
    const eval::Associated a = eval::associateByTime(in.groundtruth, in.estimate);
    if (const auto drift = eval::driftAlongPath(a, eval::kDriftScaleWindowM, chooseTopView(a.ref).up)) {
      h += "<h2>Drift against the distance driven</h2>\n<div class=\"plots\">\n";
      for (const std::string& plot : svgDriftPlots({{in.estimator, *drift, "#d95f02"}}))
        h += plot;
      h += "</div>\n";
    }
  }

  h += "<h2>Gyro bias and timing</h2>\n<div class=\"plots\">\n";
  h += biasPlot(in);
  h += timingPlot(in);
  h += resourcePlot(in);
  h += "</div>\n";
  if (in.bias_estimate.empty())
    h += fmt::format("<p class=\"note\">The {} estimator does not estimate the gyro bias.</p>\n",
                     xmlEscape(in.estimator));

  h += "<h2>Metrics</h2>\n<table>\n<tr><th>key</th><th>value</th></tr>\n";
  std::vector<std::pair<std::string, std::string>> rows;
  if (m.is_object()) flatten(m, "", rows);
  for (const auto& [k, v] : rows)
    h += fmt::format("<tr><td>{}</td><td class=\"n\">{}</td></tr>\n", xmlEscape(k), xmlEscape(v));
  h += "</table>\n";

  h += "<h2>Configuration</h2>\n";
  h += fmt::format("<pre>{}</pre>\n", in.config_yaml.empty() || in.config_yaml == "{}"
                                          ? "(defaults: no configuration file and no --set)"
                                          : xmlEscape(in.config_yaml));
  h += "</body>\n</html>\n";
  return h;
}

void writeReport(const std::filesystem::path& file, const ReportInputs& inputs) {
  // Checked to the end, the close included: a full disk shows at the last flush.
  io::writeFileAtomically(file, renderReportHtml(inputs));
}

}  // namespace ovo::app
