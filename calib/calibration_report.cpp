// report.html of `ovo calibrate camera` (calibration_output.hpp): plain HTML with inline SVG, no
// scripts and no external references, like apps/report.cpp's run report.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "calib/calibration_output.hpp"
#include "common/text.hpp"

namespace ovo::calib {
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
table { border-collapse: collapse; background: #fff; font-size: 13px; }
td, th { border: 1px solid #ddd; padding: 3px 10px; text-align: left; }
td.n { text-align: right; font-family: "DejaVu Sans Mono", monospace; }
.note { color: #666; font-size: 13px; }
)";

std::string colourOf(std::size_t k) {
  static const char* kColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                   "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  return kColours[k % 10];
}

std::string tile(const std::string& value, const std::string& label) {
  return fmt::format(
      "<div class=\"tile\"><div class=\"v\">{}</div><div class=\"k\">{}</div></div>\n",
      xmlEscape(value), xmlEscape(label));
}

// An SVG of the image's frame, `width_px` wide, with the image rectangle drawn.
struct ImageFrame {
  double scale;
  int w, h;
  std::string open(const std::string& title) const {
    return fmt::format(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} "
        "{}\"><text x=\"8\" y=\"16\" font-size=\"13\">{}</text><rect x=\"10\" y=\"24\" "
        "width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#fafafa\" stroke=\"#888\"/>\n",
        w, h, w, h, xmlEscape(title), scale * width_img, scale * height_img);
  }
  double x(double u) const { return 10.0 + scale * (u + 0.5); }
  double y(double v) const { return 24.0 + scale * (v + 0.5); }
  double width_img, height_img;
};

ImageFrame frameFor(int width, int height, int svg_width) {
  ImageFrame f;
  f.width_img = width;
  f.height_img = height;
  f.scale = (svg_width - 20.0) / std::max(1, width);
  f.w = svg_width;
  f.h = static_cast<int>(std::ceil(f.scale * height + 34.0));
  return f;
}

// The outline of a board through its border corners.
std::string boardOutline(const ImageFrame& f, const BoardObservation& b, const BoardSpec& spec,
                         const std::string& colour, bool dashed) {
  if (static_cast<int>(b.size()) != spec.cornerCount()) return "";
  std::vector<int> ring;
  for (int i = 0; i < spec.cols; ++i) ring.push_back(i);
  for (int j = 1; j < spec.rows; ++j) ring.push_back(j * spec.cols + spec.cols - 1);
  for (int i = spec.cols - 2; i >= 0; --i) ring.push_back((spec.rows - 1) * spec.cols + i);
  for (int j = spec.rows - 2; j > 0; --j) ring.push_back(j * spec.cols);
  std::string pts;
  for (int k : ring)
    pts += fmt::format("{:.1f},{:.1f} ", f.x(b.corners_px[k].x()), f.y(b.corners_px[k].y()));
  return fmt::format(
      "<polygon points=\"{}\" fill=\"{}\" fill-opacity=\"0.12\" stroke=\"{}\" "
      "stroke-width=\"1.2\"{}/>\n",
      pts, colour, colour, dashed ? " stroke-dasharray=\"4,3\"" : "");
}

std::string coverageSvg(const CalibrationRun& run) {
  const CalibrationResult& r = run.result;
  const ImageFrame f = frameFor(r.width, r.height, 560);
  std::string svg = f.open("Corner coverage (dashed grey: rejected boards)");
  for (const BoardObservation& b : run.detected) {
    const bool used = std::any_of(r.boards.begin(), r.boards.end(),
                                  [&](const BoardObservation& u) { return u.image == b.image; });
    if (!used) svg += boardOutline(f, b, run.board, "#999999", true);
  }
  for (std::size_t k = 0; k < r.boards.size(); ++k) {
    svg += boardOutline(f, r.boards[k], run.board, colourOf(k), false);
    for (const Vec2& c : r.boards[k].corners_px)
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"1.6\" fill=\"{}\"/>", f.x(c.x()),
                         f.y(c.y()), colourOf(k));
    svg += "\n";
  }
  return svg + "</svg>\n";
}

std::string residualSvg(const CalibrationRun& run) {
  const CalibrationResult& r = run.result;
  const ImageFrame f = frameFor(r.width, r.height, 560);
  std::vector<double> norms;
  for (const auto& board : r.residuals_px)
    for (const Vec2& e : board)
      if (e.allFinite()) norms.push_back(e.norm());
  std::sort(norms.begin(), norms.end());
  const double p95 = norms.empty() ? 1.0 : std::max(1e-6, norms[norms.size() * 95 / 100]);
  // Arrows magnified so that the 95th percentile is 18 SVG pixels long.
  const double gain = 18.0 / (p95 * f.scale);
  std::string svg = f.open(fmt::format(
      "Residuals (detected -> predicted) x{:.0f}; green < RMS, orange < 2 RMS, red beyond", gain));
  for (std::size_t k = 0; k < r.boards.size(); ++k)
    for (std::size_t i = 0; i < r.boards[k].size(); ++i) {
      const Vec2& c = r.boards[k].corners_px[i];
      const Vec2& e = r.residuals_px[k][i];
      if (!e.allFinite()) continue;
      const double n = e.norm();
      const char* colour = n < r.rms_px ? "#2ca02c" : n < 2.0 * r.rms_px ? "#ff7f0e" : "#d62728";
      svg += fmt::format(
          "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"{}\" "
          "stroke-width=\"1.2\"/><circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"1.2\" fill=\"{}\"/>\n",
          f.x(c.x()), f.y(c.y()), f.x(c.x() + gain * e.x()), f.y(c.y() + gain * e.y()), colour,
          f.x(c.x()), f.y(c.y()), colour);
    }
  return svg + "</svg>\n";
}

// The chosen model's held-out RMS of an image, as text ("-" when not cross-validated).
std::string heldOutText(const CalibrationRun& run, const std::string& image) {
  if (!run.selection) return "-";
  const ModelSelection& sel = *run.selection;
  const auto& per = sel.scores[sel.chosen].heldout_per_image_rms_px;
  for (std::size_t k = 0; k < sel.images.size() && k < per.size(); ++k)
    if (sel.images[k] == image && std::isfinite(per[k])) return fmt::format("{:.3f}", per[k]);
  return "-";
}

std::string perImageSvg(const CalibrationRun& run) {
  const CalibrationResult& r = run.result;
  const int n = static_cast<int>(r.boards.size());
  const int bar = 26, left = 50, top = 28, plot_h = 200, bottom = 110;
  const int w = left + n * bar + 20, h = top + plot_h + bottom;
  double top_value = r.rms_px;
  for (double v : r.per_image_rms_px) top_value = std::max(top_value, v);
  top_value *= 1.1;
  const auto y = [&](double v) { return top + plot_h * (1.0 - v / top_value); };
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} "
      "{}\"><text x=\"8\" y=\"16\" font-size=\"13\">Reprojection RMS per image [px] (line: "
      "overall {:.3f} px; dots: held out)</text>\n",
      w, h, w, h, r.rms_px);
  for (int t = 0; t <= 4; ++t) {
    const double v = top_value * t / 4.0;
    svg += fmt::format(
        "<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/><text x=\"4\" "
        "y=\"{:.1f}\" font-size=\"10\">{:.2f}</text>\n",
        left, y(v), left + n * bar, y(v), y(v) + 3, v);
  }
  for (int k = 0; k < n; ++k) {
    const double v = r.per_image_rms_px[k];
    const double x = left + k * bar + 3;
    svg += fmt::format(
        "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{}\" height=\"{:.1f}\" fill=\"{}\"><title>{}: "
        "{:.3f} px</title></rect><text transform=\"translate({:.1f},{}) rotate(60)\" "
        "font-size=\"10\">{}</text>\n",
        x, y(v), bar - 6, top + plot_h - y(v), colourOf(k), xmlEscape(r.boards[k].image), v, x + 4,
        top + plot_h + 6, xmlEscape(r.boards[k].image));
  }
  svg += fmt::format(
      "<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#222\" "
      "stroke-dasharray=\"5,3\"/>\n",
      left, y(r.rms_px), left + n * bar, y(r.rms_px));
  // The chosen model's held-out error of each image (a dot; above the plot: clipped to its top).
  for (int k = 0; k < n; ++k) {
    const std::string text = heldOutText(run, r.boards[k].image);
    if (text == "-") continue;
    const double v = std::min(std::stod(text), top_value);
    svg += fmt::format(
        "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3.5\" fill=\"#222\"><title>{} held out: {} "
        "px</title></circle>\n",
        left + k * bar + bar / 2.0, y(v), xmlEscape(r.boards[k].image), text);
  }
  return svg + "</svg>\n";
}

}  // namespace

std::string reportHtml(const CalibrationRun& run) {
  const CalibrationResult& r = run.result;
  const nlohmann::json j = reportJson(run);
  std::string html = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>ovo calibrate: " +
                     xmlEscape(modelKindName(r.model)) + "</title><style>" + kStyle +
                     "</style></head><body>\n";
  html += fmt::format(
      "<h1>Camera calibration ({})</h1><div class=\"sub\">{}x{} images, board {}x{} "
      "inner corners of {} m, corners from {}</div>\n",
      xmlEscape(modelKindName(r.model)), r.width, r.height, run.board.cols, run.board.rows,
      run.board.square_m, xmlEscape(run.source));
  html += "<div class=\"tiles\">\n";
  html += tile(fmt::format("{:.3f} px", r.rms_px), "reprojection RMS");
  html += tile(fmt::format("{:.3f} px", r.mean_of_image_means_px),
               "mean of per-image mean errors (py-OCamCalib's figure)");
  html += tile(fmt::format("{}", r.boards.size()), "images used");
  html += tile(fmt::format("{}", run.not_detected.size() + r.rejected.size()), "images rejected");
  html += tile(fmt::format("{}", r.corners_used), "corners used");
  if (run.reference)
    html += tile(fmt::format("{:.4f} deg", run.reference->max_deg),
                 "largest bearing difference to the reference");
  html += "</div>\n";
  html += "<h2>Coverage and residuals</h2><div class=\"plots\">\n" + coverageSvg(run) +
          residualSvg(run) + "</div>\n";
  if (run.selection) {
    const ModelSelection& sel = *run.selection;
    html += "<h2>Model selection</h2>\n<p class=\"note\">Chosen: " +
            xmlEscape(candidateName(sel.scores[sel.chosen].candidate)) + ", " +
            xmlEscape(sel.reason) + ".</p>\n";
    html +=
        "<table><tr><th>candidate</th><th>parameters</th><th>training RMS [px]</th>"
        "<th>held-out RMS [px]</th></tr>\n";
    for (std::size_t k = 0; k < sel.scores.size(); ++k) {
      const CandidateScore& c = sel.scores[k];
      html += fmt::format(
          "<tr><td>{}{}</td><td class=\"n\">{}</td><td class=\"n\">{:.4f}</td><td "
          "class=\"n\">{:.4f}</td></tr>\n",
          xmlEscape(candidateName(c.candidate)), k == sel.chosen ? " (chosen)" : "", c.parameters,
          c.train_rms_px, c.heldout_rms_px);
    }
    html += "</table>\n";
    for (std::size_t k = 0; k < sel.outliers.size(); ++k)
      html += fmt::format(
          "<p class=\"note\"><b>{}</b>: its corners are predicted to {:.3f} px when left out, "
          "clearly worse than the other images'; look at it, and leave it out with --exclude "
          "if its board is blurred, bent or misdetected.</p>\n",
          xmlEscape(sel.outliers[k]), sel.outlier_rms_px[k]);
  }
  html += "<h2>Per image</h2><div class=\"plots\">\n" + perImageSvg(run) + "</div>\n";
  html +=
      "<table><tr><th>image</th><th>RMS [px]</th><th>mean [px]</th><th>held-out RMS "
      "[px]</th><th>found by</th></tr>\n";
  for (std::size_t k = 0; k < r.boards.size(); ++k) {
    const auto it = run.detected_by.find(r.boards[k].image);
    html += fmt::format(
        "<tr><td>{}</td><td class=\"n\">{:.3f}</td><td class=\"n\">{:.3f}</td><td "
        "class=\"n\">{}</td><td>{}</td></tr>\n",
        xmlEscape(r.boards[k].image), r.per_image_rms_px[k], r.per_image_mean_px[k],
        heldOutText(run, r.boards[k].image),
        xmlEscape(it == run.detected_by.end() ? run.source : it->second));
  }
  html += "</table>\n<h2>Rejected images</h2>\n";
  if (run.not_detected.empty() && r.rejected.empty()) {
    html += "<p class=\"note\">none</p>\n";
  } else {
    html += "<table><tr><th>image</th><th>reason</th></tr>\n";
    for (const auto* list : {&run.not_detected, &r.rejected})
      for (const RejectedImage& rej : *list)
        html += fmt::format("<tr><td>{}</td><td>{}</td></tr>\n", xmlEscape(rej.image),
                            xmlEscape(rej.reason));
    html += "</table>\n";
  }
  html += "<h2>Model</h2><table>\n";
  if (j.contains("camera"))
    for (auto it = j["camera"].begin(); it != j["camera"].end(); ++it)
      html += fmt::format("<tr><td>{}</td><td class=\"n\">{}</td></tr>\n", xmlEscape(it.key()),
                          xmlEscape(it->dump()));
  html += fmt::format(
      "<tr><td>board shape ({})</td><td class=\"n\">shear {:.5f}, stretch "
      "{:.5f}</td></tr>\n",
      xmlEscape(j["board"]["shape"].get<std::string>()), r.board_shear, r.board_stretch);
  html += fmt::format("<tr><td>linear initialisation RMS</td><td class=\"n\">{:.3f} px</td></tr>\n",
                      r.init_rms_px);
  html += "</table>\n";
  for (const std::string& note : r.notes) html += "<p class=\"note\">" + xmlEscape(note) + "</p>\n";
  return html + "</body></html>\n";
}

}  // namespace ovo::calib
