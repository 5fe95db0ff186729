#include "calib/board_detector.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace ovo::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

BoardObservation observation(const std::vector<Vec2>& corners, const BoardSpec& spec,
                             const std::string& name, const cv::Mat& grey) {
  BoardObservation obs;
  obs.image = name;
  obs.width = grey.cols;
  obs.height = grey.rows;
  obs.corners_px = corners;
  for (int k = 0; k < spec.cornerCount(); ++k) obs.points_B.push_back(spec.point(k));
  return obs;
}

std::vector<Vec2> toVec(const std::vector<cv::Point2f>& pts) {
  std::vector<Vec2> out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.emplace_back(p.x, p.y);
  return out;
}

// Shortest distance between neighbouring corners (pixels).
double minStep(const std::vector<Vec2>& c, const BoardSpec& spec) {
  double best = std::numeric_limits<double>::infinity();
  for (int j = 0; j < spec.rows; ++j)
    for (int i = 0; i < spec.cols; ++i) {
      const int k = j * spec.cols + i;
      if (i + 1 < spec.cols) best = std::min(best, (c[k + 1] - c[k]).norm());
      if (j + 1 < spec.rows) best = std::min(best, (c[k + spec.cols] - c[k]).norm());
    }
  return best;
}

// cornerSubPix on each corner with a window of a quarter of the distance to its nearest
// neighbour (a window reaching the next corner pulls the estimate towards it; on a fisheye the
// squares shrink towards the edge), at most max_half_window.
void refineCorners(const cv::Mat& grey, const BoardSpec& spec, int max_half_window,
                   std::vector<Vec2>* corners) {
  const std::vector<Vec2> start = *corners;
  for (int k = 0; k < spec.cornerCount(); ++k) {
    const int i = k % spec.cols, j = k / spec.cols;
    double step = std::numeric_limits<double>::infinity();
    if (i > 0) step = std::min(step, (start[k] - start[k - 1]).norm());
    if (i + 1 < spec.cols) step = std::min(step, (start[k] - start[k + 1]).norm());
    if (j > 0) step = std::min(step, (start[k] - start[k - spec.cols]).norm());
    if (j + 1 < spec.rows) step = std::min(step, (start[k] - start[k + spec.cols]).norm());
    const int half =
        std::clamp(static_cast<int>(std::floor(step / 4.0)), 2, std::max(2, max_half_window));
    std::vector<cv::Point2f> pt{
        cv::Point2f(static_cast<float>(start[k].x()), static_cast<float>(start[k].y()))};
    cv::cornerSubPix(grey, pt, cv::Size(half, half), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
    (*corners)[k] = Vec2(pt[0].x, pt[0].y);
  }
}

Mat3 viewRotation(const Vec3& dir) {
  const Vec3 z = dir.normalized();
  const Vec3 hint = std::abs(z.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitX();
  const Vec3 x = hint.cross(z).normalized();
  Mat3 R;
  R << x, z.cross(x), z;
  return R;
}

}  // namespace

std::optional<std::string> gridProblem(const std::vector<Vec2>& c, const BoardSpec& spec, int width,
                                       int height, const DetectorOptions& options) {
  if (static_cast<int>(c.size()) != spec.cornerCount())
    return fmt::format("{} corners found, {} expected", c.size(), spec.cornerCount());
  for (std::size_t k = 0; k < c.size(); ++k)
    if (!c[k].allFinite() || c[k].x() < 0 || c[k].y() < 0 || c[k].x() > width - 1 ||
        c[k].y() > height - 1)
      return fmt::format("corner {} lies outside the image", k);
  if (minStep(c, spec) < 2.0) return std::string("corners closer than 2 px to each other");
  const double cos_turn = std::cos(options.max_turn_deg * kDeg);
  // Along every row and column: steps turn little and change length little.
  const auto checkLine = [&](int first, int stride, int count, const char* what,
                             int index) -> std::optional<std::string> {
    for (int i = 1; i + 1 < count; ++i) {
      const Vec2 a = c[first + i * stride] - c[first + (i - 1) * stride];
      const Vec2 b = c[first + (i + 1) * stride] - c[first + i * stride];
      const double ratio = b.norm() / a.norm();
      if (!(ratio < options.max_step_ratio && ratio > 1.0 / options.max_step_ratio))
        return fmt::format("corner spacing along {} {} jumps by {:.1f}x", what, index, ratio);
      if (a.dot(b) < cos_turn * a.norm() * b.norm())
        return fmt::format("the corner grid bends by more than {:.0f} deg along {} {}",
                           options.max_turn_deg, what, index);
    }
    return std::nullopt;
  };
  for (int j = 0; j < spec.rows; ++j)
    if (auto p = checkLine(j * spec.cols, 1, spec.cols, "row", j)) return p;
  for (int i = 0; i < spec.cols; ++i)
    if (auto p = checkLine(i, spec.cols, spec.rows, "column", i)) return p;
  // Every cell has the same handedness: the grid does not fold over.
  int sign = 0;
  for (int j = 0; j + 1 < spec.rows; ++j)
    for (int i = 0; i + 1 < spec.cols; ++i) {
      const int k = j * spec.cols + i;
      const Vec2 a = c[k + 1] - c[k], b = c[k + spec.cols] - c[k];
      const int s = a.x() * b.y() - a.y() * b.x() > 0 ? 1 : -1;
      if (sign == 0) sign = s;
      if (s != sign) return fmt::format("the corner grid folds over at row {}, column {}", j, i);
    }
  return std::nullopt;
}

Detection detectBoard(const cv::Mat& grey, const BoardSpec& spec, const std::string& name,
                      const DetectorOptions& options) {
  Detection out;
  const cv::Size pattern(spec.cols, spec.rows);
  std::vector<std::string> problems;
  std::vector<cv::Point2f> pts;
  // SB's own accuracy mode (CALIB_CB_ACCURACY) costs much more time and gains nothing after
  // cornerSubPix.
  if (cv::findChessboardCornersSB(grey, pattern, pts, cv::CALIB_CB_EXHAUSTIVE)) {
    std::vector<Vec2> corners = toVec(pts);
    refineCorners(grey, spec, options.subpix_half_window_px, &corners);
    if (auto p = gridProblem(corners, spec, grey.cols, grey.rows, options)) {
      problems.push_back("SB detector: " + *p);
    } else {
      out.board = observation(corners, spec, name, grey);
      out.method = "image (SB)";
      return out;
    }
  }
  pts.clear();
  if (cv::findChessboardCorners(grey, pattern, pts,
                                cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE |
                                    cv::CALIB_CB_FILTER_QUADS)) {
    std::vector<Vec2> corners = toVec(pts);
    refineCorners(grey, spec, options.subpix_half_window_px, &corners);
    if (auto p = gridProblem(corners, spec, grey.cols, grey.rows, options)) {
      problems.push_back("classic detector: " + *p);
    } else {
      out.board = observation(corners, spec, name, grey);
      out.method = "image (classic)";
      return out;
    }
  }
  if (problems.empty()) {
    out.reason =
        fmt::format("no {}x{} board found (inner corners, columns x rows)", spec.cols, spec.rows);
  } else {
    out.reason = "detection refused: ";
    for (std::size_t i = 0; i < problems.size(); ++i) out.reason += (i ? "; " : "") + problems[i];
  }
  return out;
}

Detection detectBoardInViews(const cv::Mat& grey, const BoardSpec& spec, const std::string& name,
                             const camera::Camera& model, const DetectorOptions& options) {
  Detection out;
  out.reason = fmt::format("no {}x{} board found in the image or in its perspective views",
                           spec.cols, spec.rows);
  if (grey.cols != camera::width(model) || grey.rows != camera::height(model)) {
    out.reason = "the image size differs from the first calibration's";
    return out;
  }
  std::vector<Vec3> directions{Vec3::UnitZ()};
  for (const auto& [ring_deg, count] : {std::pair{50.0, 6}, std::pair{85.0, 8}})
    for (int a = 0; a < count; ++a) {
      const double az = 2.0 * M_PI * a / count, off = ring_deg * kDeg;
      directions.emplace_back(std::sin(off) * std::cos(az), std::sin(off) * std::sin(az),
                              std::cos(off));
    }
  const int n = options.view_size_px;
  const double f = 0.5 * n / std::tan(0.5 * options.view_fov_deg * kDeg);
  const double c = 0.5 * (n - 1);
  const cv::Size pattern(spec.cols, spec.rows);
  std::string last_problem;
  for (const Vec3& dir : directions) {
    const Mat3 R_C_V = viewRotation(dir);
    cv::Mat map_u(n, n, CV_32F), map_v(n, n, CV_32F);
    int inside = 0;
    for (int b = 0; b < n; ++b)
      for (int a = 0; a < n; ++a) {
        const auto px = camera::project(model, R_C_V * Vec3((a - c) / f, (b - c) / f, 1.0));
        const bool ok = px && camera::isValid(model, *px);
        map_u.at<float>(b, a) = ok ? static_cast<float>(px->x()) : -1.0f;
        map_v.at<float>(b, a) = ok ? static_cast<float>(px->y()) : -1.0f;
        inside += ok;
      }
    if (inside < n * n / 4) continue;  // the view lies mostly outside the image
    cv::Mat view;
    cv::remap(grey, view, map_u, map_v, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    std::vector<cv::Point2f> pts;
    if (!cv::findChessboardCornersSB(view, pattern, pts, cv::CALIB_CB_EXHAUSTIVE)) continue;
    std::vector<Vec2> corners;
    bool mapped = true;
    for (const auto& p : pts) {
      const auto px = camera::project(model, R_C_V * Vec3((p.x - c) / f, (p.y - c) / f, 1.0));
      if (!px || !camera::isValid(model, *px)) {
        mapped = false;
        break;
      }
      corners.push_back(*px);
    }
    if (!mapped) continue;
    refineCorners(grey, spec, options.subpix_half_window_px, &corners);
    if (auto p = gridProblem(corners, spec, grey.cols, grey.rows, options)) {
      last_problem = *p;
      continue;
    }
    out.board = observation(corners, spec, name, grey);
    out.method = "perspective view";
    out.reason.clear();
    return out;
  }
  if (!last_problem.empty())
    out.reason += " (a view's detection was refused: " + last_problem + ")";
  return out;
}

}  // namespace ovo::calib
