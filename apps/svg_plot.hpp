// Small self-contained SVG line plots for report.html and `ovo eval --plot`, and the trajectory
// comparison they show (top view after SE(3) alignment, position and yaw error over time).
// Output is plain SVG 1.1 text: no scripts, no external references, never a NaN coordinate.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/text.hpp"
#include "common/types.hpp"
#include "eval/metrics.hpp"

namespace ovo::app {

/// One polyline (or point set) of a plot; a point with a non-finite coordinate breaks the line.
struct PlotSeries {
  std::string label;  // legend text (no legend entry when empty)
  std::vector<double> x, y;
  std::string color = "#1f77b4";  // any SVG colour
  bool dashed = false;
  double width_px = 1.6;
  double marker_px = 0.0;  // > 0: a dot of this radius at every point instead of a line
};

struct PlotOptions {
  std::string title, x_label, y_label;
  int width_px = 640, height_px = 360;
  bool equal_aspect = false;    // one data unit is equally long on both axes (top views)
  bool y_include_zero = false;  // the y range reaches 0 (errors, times)
};

/// The data -> pixel mapping of a plot (y up in data, down in pixels).
struct PlotFrame {
  double x_min = 0, x_max = 1, y_min = 0, y_max = 1;            // data range shown
  double left_px = 0, top_px = 0, width_px = 1, height_px = 1;  // plot area inside the SVG
  Vec2 toPx(double x, double y) const;
};

/// The plot area and data range for these series (finite points only; padded; equal aspect
/// widens the shorter range).
PlotFrame plotFrame(const std::vector<PlotSeries>& series, const PlotOptions& options);

/// About `target` (at least 2) round tick values (1, 2, 5 x 10^k steps) inside [lo, hi].
std::vector<double> niceTicks(double lo, double hi, int target = 6);

/// A line plot as one standalone <svg> element (embeddable in HTML as it is).
std::string svgLinePlot(const std::vector<PlotSeries>& series, const PlotOptions& options);

/// The horizontal plane of a world frame for top views: the world axis along which the
/// reference moves least is taken as up (+z for gravity-aligned ovo/EuRoC worlds, -y for
/// camera-frame worlds such as KITTI's, whose y points down); a and b span the plane with
/// a x b = up, so the view is seen from above and never mirrored.
struct TopView {
  Vec3 up = Vec3::UnitZ(), axis_a = Vec3::UnitX(), axis_b = Vec3::UnitY();
  std::string a_name = "x", b_name = "y";  // axis labels, e.g. "x" and "z"
  Vec2 project(const Vec3& p_W) const { return {axis_a.dot(p_W), axis_b.dot(p_W)}; }
};
TopView chooseTopView(const Trajectory& reference);

/// An estimate against a reference for plotting: associated by time, the estimate SE(3)-aligned
/// onto the reference (Umeyama; by the first pose when that is degenerate), per-pair position
/// error and yaw error about the view's up axis.
struct TrajectoryComparison {
  TopView view;
  std::string alignment = "SE(3)";         // or "first pose"
  Trajectory reference, estimate_aligned;  // associated pairs
  std::vector<double> t_s;                 // time since the first pair [s]
  std::vector<double> pos_err_m, yaw_err_deg;
};
/// nullopt when fewer than 3 poses associate.
std::optional<TrajectoryComparison> compareTrajectories(const Trajectory& reference,
                                                        const Trajectory& estimate,
                                                        Timestamp max_diff_ns = 20'000'000);

/// Top view of the reference and the aligned estimate.
std::string svgTopView(const TrajectoryComparison& c, const std::string& title = "Top view",
                       int size_px = 520);
/// A top view of one trajectory alone (no reference).
std::string svgTopViewSingle(const Trajectory& trajectory, const std::string& title = "Top view",
                             int size_px = 520);
/// Position error [m] and yaw error [deg] over time.
std::string svgErrorsOverTime(const TrajectoryComparison& c, int width_px = 640);
/// `ovo eval --plot`: top view and errors over time side by side in one SVG document.
std::string svgComparisonDocument(const TrajectoryComparison& c, const std::string& title,
                                  const std::string& time_label = "time [s]");

/// One estimator's drift against the distance driven (eval::driftAlongPath), for plotting.
struct DriftSeries {
  std::string label;
  eval::DriftCurve curve;
  std::string color = "#1f77b4";
};
/// Position, heading and scale error against the distance driven, one line per series: three
/// <svg> plots (position, heading, scale), each embeddable as it is.
std::vector<std::string> svgDriftPlots(const std::vector<DriftSeries>& series,
                                       int width_px = 640);
/// `ovo eval --drift-plot`: the three plots stacked in one SVG document.
std::string svgDriftDocument(const std::vector<DriftSeries>& series, const std::string& title);

}  // namespace ovo::app
