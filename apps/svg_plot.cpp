#include "apps/svg_plot.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "eval/align.hpp"
#include "eval/metrics.hpp"

namespace ovo::app {
namespace {

constexpr double kLeftPx = 64, kRightPx = 16, kTopPx = 34, kBottomPx = 46;

bool finite2(double x, double y) { return std::isfinite(x) && std::isfinite(y); }

// A standalone SVG document's opening (white background, a title), closed by "</svg>\n".
std::string documentHeader(int width, int height, const std::string& title) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" +
         fmt::format(
             "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
             "viewBox=\"0 0 {0} {1}\" font-family=\"DejaVu Sans, Arial, sans-serif\">\n"
             "<rect x=\"0\" y=\"0\" width=\"{0}\" height=\"{1}\" fill=\"#ffffff\"/>\n"
             "<text x=\"12\" y=\"20\" font-size=\"15\" font-weight=\"bold\">{2}</text>\n",
             width, height, xmlEscape(title));
}

// A plot (an <svg> element) nested in a document at (x, y): its x/y attributes place it.
std::string placed(const std::string& svg, int x, int y) {
  return fmt::format("<svg x=\"{}\" y=\"{}\"", x, y) + svg.substr(4);
}

// Shortest round-trip text for a tick value (0.30000000000000004 -> "0.3").
std::string tickLabel(double v, double step) {
  if (std::abs(v) < 1e-9 * std::max(1.0, std::abs(step))) v = 0.0;
  const int decimals = std::clamp(static_cast<int>(std::ceil(-std::log10(step))), 0, 6);
  return fmt::format("{:.{}f}", v, decimals);
}

std::string num(double v) { return fmt::format("{:.2f}", v); }

}  // namespace

Vec2 PlotFrame::toPx(double x, double y) const {
  return {left_px + (x - x_min) / (x_max - x_min) * width_px,
          top_px + (y_max - y) / (y_max - y_min) * height_px};
}

namespace {

// Ticks at 1, 2 or 5 x 10^k steps of about (hi - lo) / target.
std::vector<double> niceTicksWithTarget(double lo, double hi, int target) {
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  std::vector<double> ticks;
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step)
    ticks.push_back(v);
  return ticks;
}

}  // namespace

std::vector<double> niceTicks(double lo, double hi, int target) {
  if (!(std::isfinite(lo) && std::isfinite(hi)) || hi <= lo || target < 1) return {};
  // At least two ticks, so that every axis shows its scale.
  std::vector<double> ticks;
  for (int t = target; t <= 4 * target && ticks.size() < 2; ++t)
    ticks = niceTicksWithTarget(lo, hi, t);
  return ticks;
}

PlotFrame plotFrame(const std::vector<PlotSeries>& series, const PlotOptions& options) {
  PlotFrame f;
  f.left_px = kLeftPx;
  f.top_px = kTopPx;
  f.width_px = std::max(10.0, options.width_px - kLeftPx - kRightPx);
  f.height_px = std::max(10.0, options.height_px - kTopPx - kBottomPx);
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : series)
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i)
      if (finite2(s.x[i], s.y[i])) {
        x0 = std::min(x0, s.x[i]);
        x1 = std::max(x1, s.x[i]);
        y0 = std::min(y0, s.y[i]);
        y1 = std::max(y1, s.y[i]);
      }
  if (!(x0 <= x1)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;  // no finite point at all
  if (options.y_include_zero) y0 = std::min(y0, 0.0), y1 = std::max(y1, 0.0);
  auto widen = [](double& lo, double& hi) {
    const double span = hi - lo;
    const double pad = span > 0 ? 0.04 * span : std::max(0.5, 0.1 * std::abs(lo));
    lo -= pad;
    hi += pad;
  };
  widen(x0, x1);
  widen(y0, y1);
  if (options.equal_aspect) {
    const double units_per_px = std::max((x1 - x0) / f.width_px, (y1 - y0) / f.height_px);
    const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
    x0 = cx - 0.5 * units_per_px * f.width_px;
    x1 = cx + 0.5 * units_per_px * f.width_px;
    y0 = cy - 0.5 * units_per_px * f.height_px;
    y1 = cy + 0.5 * units_per_px * f.height_px;
  }
  f.x_min = x0, f.x_max = x1, f.y_min = y0, f.y_max = y1;
  return f;
}

std::string svgLinePlot(const std::vector<PlotSeries>& series, const PlotOptions& options) {
  const PlotFrame f = plotFrame(series, options);
  const int W = options.width_px, H = options.height_px;
  std::string s = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\" font-family=\"DejaVu Sans, Arial, sans-serif\" "
      "font-size=\"11\">\n",
      W, H);
  s += fmt::format("<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"#ffffff\"/>\n", W, H);
  if (!options.title.empty())
    s += fmt::format(
        "<text x=\"{}\" y=\"20\" text-anchor=\"middle\" font-size=\"14\" font-weight=\"bold\">"
        "{}</text>\n",
        num(f.left_px + 0.5 * f.width_px), xmlEscape(options.title));

  // Grid and tick labels.
  s += "<g stroke=\"#e3e3e3\" stroke-width=\"1\">\n";
  const auto xt = niceTicks(f.x_min, f.x_max, std::max(2, static_cast<int>(f.width_px / 90)));
  const auto yt = niceTicks(f.y_min, f.y_max, std::max(2, static_cast<int>(f.height_px / 60)));
  for (const double x : xt) {
    const double px = f.toPx(x, 0).x();
    s += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\"/>\n", num(px),
                     num(f.top_px), num(f.top_px + f.height_px));
  }
  for (const double y : yt) {
    const double py = f.toPx(0, y).y();
    s += fmt::format("<line x1=\"{1}\" y1=\"{0}\" x2=\"{2}\" y2=\"{0}\"/>\n", num(py),
                     num(f.left_px), num(f.left_px + f.width_px));
  }
  s += "</g>\n<g fill=\"#444444\">\n";
  const double x_step = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
  const double y_step = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (const double x : xt)
    s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
                     num(f.toPx(x, 0).x()), num(f.top_px + f.height_px + 15), tickLabel(x, x_step));
  for (const double y : yt)
    s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>\n", num(f.left_px - 6),
                     num(f.toPx(0, y).y() + 4), tickLabel(y, y_step));
  s += "</g>\n";
  s += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888888\"/>\n",
      num(f.left_px), num(f.top_px), num(f.width_px), num(f.height_px));
  if (!options.x_label.empty())
    s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
                     num(f.left_px + 0.5 * f.width_px), H - 8, xmlEscape(options.x_label));
  if (!options.y_label.empty())
    s += fmt::format(
        "<text x=\"14\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 14 {0})\">{1}"
        "</text>\n",
        num(f.top_px + 0.5 * f.height_px), xmlEscape(options.y_label));

  // Data, clipped to the plot area.
  static std::atomic<int> clip_counter{0};  // ids unique within one document
  const std::string clip_id = fmt::format("clip{}", clip_counter++);
  s += fmt::format(
      "<clipPath id=\"{}\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/></clipPath>\n",
      clip_id, num(f.left_px), num(f.top_px), num(f.width_px), num(f.height_px));
  s += fmt::format("<g clip-path=\"url(#{})\" fill=\"none\">\n", clip_id);
  for (const auto& ser : series) {
    const std::size_t n = std::min(ser.x.size(), ser.y.size());
    if (ser.marker_px > 0) {
      s += fmt::format("<g fill=\"{}\" stroke=\"none\">", xmlEscape(ser.color));
      for (std::size_t i = 0; i < n; ++i) {
        if (!finite2(ser.x[i], ser.y[i])) continue;
        const Vec2 p = f.toPx(ser.x[i], ser.y[i]);
        s += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"{}\"/>", num(p.x()), num(p.y()),
                         num(ser.marker_px));
      }
      s += "</g>\n";
      continue;
    }
    std::string points;
    auto flush = [&] {
      if (!points.empty())
        s += fmt::format(
            "<polyline points=\"{}\" stroke=\"{}\" stroke-width=\"{}\"{} "
            "stroke-linejoin=\"round\"/>\n",
            points, xmlEscape(ser.color), num(ser.width_px),
            ser.dashed ? " stroke-dasharray=\"6 4\"" : "");
      points.clear();
    };
    for (std::size_t i = 0; i < n; ++i) {
      if (!finite2(ser.x[i], ser.y[i])) {
        flush();
        continue;
      }
      const Vec2 p = f.toPx(ser.x[i], ser.y[i]);
      if (!points.empty()) points += ' ';
      points += num(p.x()) + "," + num(p.y());
    }
    flush();
  }
  s += "</g>\n";

  // Legend, top right inside the plot area.
  int entries = 0;
  for (const auto& ser : series) entries += ser.label.empty() ? 0 : 1;
  if (entries > 0) {
    std::size_t longest = 0;
    for (const auto& ser : series) longest = std::max(longest, ser.label.size());
    const double w = 34 + 6.5 * static_cast<double>(longest), h = 8 + 16.0 * entries;
    const double x = f.left_px + f.width_px - w - 6, y = f.top_px + 6;
    s += fmt::format(
        "<g><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#ffffff\" "
        "fill-opacity=\"0.85\" stroke=\"#bbbbbb\"/>\n",
        num(x), num(y), num(w), num(h));
    int k = 0;
    for (const auto& ser : series) {
      if (ser.label.empty()) continue;
      const double ly = y + 14 + 16.0 * k++;
      if (ser.marker_px > 0)
        s += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"3\" fill=\"{}\"/>", num(x + 15),
                         num(ly - 4), xmlEscape(ser.color));
      else
        s += fmt::format(
            "<line x1=\"{0}\" y1=\"{2}\" x2=\"{1}\" y2=\"{2}\" stroke=\"{3}\" "
            "stroke-width=\"2\"{4}/>",
            num(x + 6), num(x + 26), num(ly - 4), xmlEscape(ser.color),
            ser.dashed ? " stroke-dasharray=\"5 3\"" : "");
      s += fmt::format("<text x=\"{}\" y=\"{}\">{}</text>\n", num(x + 30), num(ly),
                       xmlEscape(ser.label));
    }
    s += "</g>\n";
  }
  s += "</svg>\n";
  return s;
}

TopView chooseTopView(const Trajectory& reference) {
  const TopView z_up{Vec3::UnitZ(), Vec3::UnitX(), Vec3::UnitY(), "x", "y"};
  const TopView y_down{-Vec3::UnitY(), Vec3::UnitX(), Vec3::UnitZ(), "x", "z"};
  const TopView x_up{Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ(), "y", "z"};
  if (reference.size() < 3) return z_up;

  Vec3 mean = Vec3::Zero();
  for (const auto& p : reference) mean += p.T_W_B.translation();
  mean /= static_cast<double>(reference.size());
  Mat3 cov = Mat3::Zero();
  for (const auto& p : reference) {
    const Vec3 d = p.T_W_B.translation() - mean;
    cov += d * d.transpose();
  }
  if (!cov.allFinite() || cov.trace() <= 0) return z_up;
  Eigen::SelfAdjointEigenSolver<Mat3> es(cov);
  const Vec3 lambda = es.eigenvalues();  // ascending
  auto axisView = [&](int k) { return k == 2 ? z_up : (k == 1 ? y_down : x_up); };
  if (lambda(1) < 0.05 * lambda(2)) {
    // Nearly a straight line: any plane holding it will do; z up unless the line runs along z.
    const Vec3 dir = es.eigenvectors().col(2);
    return std::abs(dir.z()) < 0.7 ? z_up : y_down;
  }
  // The normal of the plane of motion picks the world axis closest to it.
  const Vec3 normal = es.eigenvectors().col(0).cwiseAbs();
  int k = 2;
  normal.maxCoeff(&k);
  return axisView(k);
}

std::optional<TrajectoryComparison> compareTrajectories(const Trajectory& reference,
                                                        const Trajectory& estimate,
                                                        Timestamp max_diff_ns) {
  const eval::Associated a = eval::associateByTime(reference, estimate, max_diff_ns);
  if (a.size() < 3) return std::nullopt;
  TrajectoryComparison c;
  auto S = eval::alignTrajectories(a.ref, a.est, eval::AlignMode::kSE3);
  if (!S) {
    // Degenerate for Umeyama (e.g. an estimate that never moved): put the first poses together.
    S = eval::alignFirstPose(a.ref, a.est);
    c.alignment = "first pose";
  }
  if (!S) return std::nullopt;
  c.view = chooseTopView(a.ref);
  c.reference = a.ref;
  c.estimate_aligned = eval::transformed(a.est, *S);
  const Timestamp t0 = a.ref.front().t_ns;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const SE3& T_ref = c.reference[i].T_W_B;
    const SE3& T_est = c.estimate_aligned[i].T_W_B;
    c.t_s.push_back(toSeconds(c.reference[i].t_ns - t0));
    c.pos_err_m.push_back((T_est.translation() - T_ref.translation()).norm());
    // Heading error: the world-frame rotation error applied to a horizontal axis, measured in
    // the horizontal plane.
    const Vec3 v = T_est.linear() * T_ref.linear().transpose() * c.view.axis_a;
    const double yaw = std::atan2(v.dot(c.view.axis_b), v.dot(c.view.axis_a)) * 180.0 / M_PI;
    c.yaw_err_deg.push_back(std::isfinite(yaw) ? yaw : 0.0);
  }
  return c;
}

namespace {

PlotSeries topSeries(const Trajectory& t, const TopView& view, std::string label, std::string color,
                     bool dashed) {
  PlotSeries s;
  s.label = std::move(label);
  s.color = std::move(color);
  s.dashed = dashed;
  for (const auto& p : t) {
    const Vec2 q = view.project(p.T_W_B.translation());
    s.x.push_back(q.x());
    s.y.push_back(q.y());
  }
  return s;
}

PlotSeries startMarker(const Trajectory& t, const TopView& view) {
  PlotSeries s;
  s.label = "start";
  s.color = "#2ca02c";
  s.marker_px = 4.5;
  if (!t.empty()) {
    const Vec2 q = view.project(t.front().T_W_B.translation());
    s.x = {q.x()};
    s.y = {q.y()};
  }
  return s;
}

}  // namespace

std::string svgTopView(const TrajectoryComparison& c, const std::string& title, int size_px) {
  PlotOptions o;
  o.title = title;
  o.width_px = size_px;
  o.height_px = size_px;
  o.equal_aspect = true;
  o.x_label = c.view.a_name + " [m]";
  o.y_label = c.view.b_name + " [m]";
  return svgLinePlot(
      {topSeries(c.reference, c.view, "ground truth", "#333333", true),
       topSeries(c.estimate_aligned, c.view, "estimate (SE(3)-aligned)", "#d95f02", false),
       startMarker(c.reference, c.view)},
      o);
}

std::string svgTopViewSingle(const Trajectory& trajectory, const std::string& title, int size_px) {
  const TopView view = chooseTopView(trajectory);
  PlotOptions o;
  o.title = title;
  o.width_px = size_px;
  o.height_px = size_px;
  o.equal_aspect = true;
  o.x_label = view.a_name + " [m]";
  o.y_label = view.b_name + " [m]";
  return svgLinePlot(
      {topSeries(trajectory, view, "estimate", "#d95f02", false), startMarker(trajectory, view)},
      o);
}

std::string svgErrorsOverTime(const TrajectoryComparison& c, int width_px) {
  PlotOptions o;
  o.width_px = width_px;
  o.height_px = 260;
  o.x_label = "time [s]";
  PlotSeries pos{"position error", c.t_s, c.pos_err_m, "#d95f02"};
  o.y_include_zero = true;
  o.title = "Position error (" + c.alignment + "-aligned)";
  o.y_label = "error [m]";
  std::string s = svgLinePlot({pos}, o);
  PlotSeries yaw{"yaw error", c.t_s, c.yaw_err_deg, "#7570b3"};
  o.y_include_zero = false;
  o.title = "Yaw error (" + c.alignment + "-aligned)";
  o.y_label = "error [deg]";
  return s + svgLinePlot({yaw}, o);
}

std::string svgComparisonDocument(const TrajectoryComparison& c, const std::string& title,
                                  const std::string& time_label) {
  constexpr int kTop = 560, kErrW = 640;
  const std::string top = svgTopView(c, "Top view", kTop);
  PlotOptions o;
  o.width_px = kErrW;
  o.height_px = kTop / 2;
  o.x_label = time_label;
  o.title = "Position error";
  o.y_label = "error [m]";
  o.y_include_zero = true;
  const std::string pos = svgLinePlot({{"", c.t_s, c.pos_err_m, "#d95f02"}}, o);
  o.title = "Yaw error";
  o.y_label = "error [deg]";
  o.y_include_zero = false;
  const std::string yaw = svgLinePlot({{"", c.t_s, c.yaw_err_deg, "#7570b3"}}, o);
  std::string s = documentHeader(kTop + kErrW, kTop + 30, title);
  s += placed(top, 0, 30);
  s += placed(pos, kTop, 30);
  s += placed(yaw, kTop, 30 + kTop / 2);
  s += "</svg>\n";
  return s;
}

std::vector<std::string> svgDriftPlots(const std::vector<DriftSeries>& series, int width_px) {
  // At most one point per 0.5 m of path: a working session has tens of thousands of poses.
  constexpr double kSpacingM = 0.5;
  std::vector<PlotSeries> pos, yaw, scale;
  for (const DriftSeries& d : series) {
    PlotSeries p{d.label, {}, {}, d.color}, y{d.label, {}, {}, d.color},
        s{d.label, {}, {}, d.color};
    const eval::DriftCurve& c = d.curve;
    double next = -1.0;
    for (std::size_t i = 0; i < c.distance_m.size(); ++i) {
      if (c.distance_m[i] < next && i + 1 < c.distance_m.size()) continue;
      next = c.distance_m[i] + kSpacingM;
      p.x.push_back(c.distance_m[i]), p.y.push_back(c.pos_err_m[i]);
      y.x.push_back(c.distance_m[i]), y.y.push_back(c.yaw_err_deg[i]);
      s.x.push_back(c.distance_m[i]), s.y.push_back(c.scale_err_pct[i]);
    }
    pos.push_back(std::move(p));
    yaw.push_back(std::move(y));
    scale.push_back(std::move(s));
  }
  PlotOptions o;
  o.width_px = width_px;
  o.height_px = 260;
  o.x_label = "distance driven [m]";
  o.y_include_zero = true;
  o.title = "Position error (aligned on the first pose)";
  o.y_label = "error [m]";
  std::vector<std::string> out{svgLinePlot(pos, o)};
  o.title = "Heading error (aligned on the first pose)";
  o.y_label = "error [deg]";
  out.push_back(svgLinePlot(yaw, o));
  o.title = fmt::format("Scale error over the last {:g} m", eval::kDriftScaleWindowM);
  o.y_label = "error [%]";
  out.push_back(svgLinePlot(scale, o));
  return out;
}

std::string svgDriftDocument(const std::vector<DriftSeries>& series, const std::string& title) {
  constexpr int kW = 760, kH = 260;
  const std::vector<std::string> plots = svgDriftPlots(series, kW);
  std::string s = documentHeader(kW, 30 + kH * static_cast<int>(plots.size()), title);
  for (std::size_t k = 0; k < plots.size(); ++k)
    s += placed(plots[k], 0, 30 + kH * static_cast<int>(k));
  s += "</svg>\n";
  return s;
}

}  // namespace ovo::app
