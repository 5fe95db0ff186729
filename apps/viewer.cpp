#include "apps/viewer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <limits>
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "common/error.hpp"

namespace ovo::app {
namespace {

constexpr int kStatusHeightPx = 30;
constexpr int kMaxAgeColour = 30;  // tracks this old or older get the last colour
constexpr std::size_t kMaxTracksDrawn = 700;
const cv::Scalar kLidarColour(255, 0, 255);
const cv::Scalar kEstimateColour(0, 140, 255);
const cv::Scalar kTruthColour(90, 150, 90);
const cv::Scalar kTextColour(235, 235, 235);

// Track age -> colour (turbo colour map, young = blue, old = red).
cv::Scalar ageColour(int age) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(0, i) = static_cast<std::uint8_t>(i);
    cv::Mat colours;
    cv::applyColorMap(ramp, colours, cv::COLORMAP_TURBO);
    return colours;
  }();
  const double f = std::clamp((age - 2.0) / (kMaxAgeColour - 2.0), 0.0, 1.0);
  const auto c = lut.at<cv::Vec3b>(0, static_cast<int>(40 + f * 210));
  return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
}

void putText(cv::Mat& img, const std::string& text, cv::Point at, double scale = 0.45,
             const cv::Scalar& colour = kTextColour, int thickness = 1) {
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), thickness + 2,
              cv::LINE_AA);
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv::LINE_AA);
}

cv::Point toPoint(const Vec2& p) {
  return {static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))};
}

}  // namespace

std::vector<ProjectedBeam> projectScan(const LidarScan& scan, const SE3& T_C_L,
                                       const camera::Camera& camera) {
  std::vector<ProjectedBeam> beams;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    if (!scan.valid(i)) continue;
    const Vec3 p_C = T_C_L * scan.point_L(i);
    const auto px = camera::project(camera, p_C);
    if (!px || !camera::isValid(camera, *px)) continue;
    beams.push_back({*px, scan.ranges_m[i]});
  }
  return beams;
}

Viewer::Viewer(const estimator::SensorSetup& setup, std::string estimator_name,
               ViewerOptions options)
    : setup_(setup),
      T_C_L_(setup.T_B_C.inverse() * setup.T_B_L),
      estimator_name_(std::move(estimator_name)),
      options_(std::move(options)) {}

void Viewer::setGroundTruth(const Trajectory& groundtruth) {
  std::lock_guard lock(mutex_);
  groundtruth_ = groundtruth;
  view_ =
      groundtruth.size() >= 3 ? std::optional<TopView>(chooseTopView(groundtruth)) : std::nullopt;
  ++version_;
}

void Viewer::addScan(const LidarScan& scan) {
  std::lock_guard lock(mutex_);
  if (!scans_.empty() && scan.t_ns <= scans_.back().t_ns) return;
  scans_.push_back(scan);
  while (scans_.size() > 30) scans_.pop_front();
}

void Viewer::addFrame(const estimator::FrameEstimate& estimate, const cv::Mat& grey,
                      const ViewerFrameInfo& info) {
  std::lock_guard lock(mutex_);
  if (!T_Wgt_W_ && !groundtruth_.empty()) {
    // Put the estimate's world onto the ground truth's by the pose nearest in time.
    const auto it = std::min_element(
        groundtruth_.begin(), groundtruth_.end(), [&](const StampedPose& a, const StampedPose& b) {
          return std::abs(a.t_ns - estimate.t_ns) < std::abs(b.t_ns - estimate.t_ns);
        });
    if (std::abs(it->t_ns - estimate.t_ns) < 100'000'000)
      T_Wgt_W_ = it->T_W_B * estimate.T_W_B.inverse();
  }
  const SE3 T = T_Wgt_W_.value_or(SE3::Identity()) * estimate.T_W_B;
  if (allFinite(T)) positions_W_.push_back(T.translation());
  std::map<std::uint64_t, std::vector<Vec2>> trails;
  std::map<std::uint64_t, int> ages;
  for (const auto& tr : estimate.tracks) {
    auto& trail = trails[tr.id];
    if (const auto it = trails_.find(tr.id); it != trails_.end()) trail = std::move(it->second);
    trail.push_back(tr.px);
    if (static_cast<int>(trail.size()) > options_.trail_length) trail.erase(trail.begin());
    ages[tr.id] = tr.age;
  }
  trails_ = std::move(trails);
  ages_ = std::move(ages);
  grey_ = grey;
  last_ = estimate;
  estimator::dropTracks(*last_);
  info_ = info;
  ++frames_;
  ++version_;
}

cv::Mat Viewer::renderImagePanel() const {
  const int H = options_.panel_height_px;
  if (grey_.empty()) {
    cv::Mat panel(H, H * 4 / 3, CV_8UC3, cv::Scalar(20, 20, 20));
    putText(panel, "waiting for images", {20, H / 2}, 0.7);
    return panel;
  }
  const double s = std::min(static_cast<double>(H) / grey_.rows,
                            static_cast<double>(options_.max_image_width_px) / grey_.cols);
  cv::Mat scaled, img;
  cv::resize(grey_, scaled, cv::Size(), s, s, s < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  cv::cvtColor(scaled, img, cv::COLOR_GRAY2BGR);
  cv::Mat panel(H, img.cols, CV_8UC3, cv::Scalar(20, 20, 20));
  const int y0 = (H - img.rows) / 2;
  img.copyTo(panel(cv::Rect(0, y0, img.cols, img.rows)));
  const Vec2 offset(0.5 * (s - 1.0), 0.5 * (s - 1.0) + y0);  // pixel centres scale about (−½, −½)
  auto toPanel = [&](const Vec2& px) { return toPoint(px * s + offset); };

  // LiDAR: the scan nearest in time to the frame.
  const LidarScan* scan = nullptr;
  Timestamp best = 250'000'000;
  for (const auto& sc : scans_)
    if (last_ && std::abs(sc.t_ns - last_->t_ns) <= best) {
      best = std::abs(sc.t_ns - last_->t_ns);
      scan = &sc;
    }
  int lidar_points = 0;
  if (scan)
    for (const auto& b : projectScan(*scan, T_C_L_, setup_.camera)) {
      cv::circle(panel, toPanel(b.px), 3, cv::Scalar(0, 0, 0), cv::FILLED, cv::LINE_AA);
      cv::circle(panel, toPanel(b.px), 2, kLidarColour, cv::FILLED, cv::LINE_AA);
      ++lidar_points;
    }

  // Tracks: trails coloured by age, oldest drawn last (on top).
  // At most ~kMaxTracksDrawn, an even subsample by id when there are more (legibility).
  const std::uint64_t every = (ages_.size() + kMaxTracksDrawn - 1) / kMaxTracksDrawn;
  std::vector<std::pair<int, std::uint64_t>> order;
  for (const auto& [id, age] : ages_)
    if (every <= 1 || id % every == 0) order.push_back({age, id});
  std::sort(order.begin(), order.end());
  for (const auto& [age, id] : order) {
    const auto& trail = trails_.at(id);
    const cv::Scalar c = ageColour(age);
    for (std::size_t i = 1; i < trail.size(); ++i)
      cv::line(panel, toPanel(trail[i - 1]), toPanel(trail[i]), c, 1, cv::LINE_AA);
    cv::circle(panel, toPanel(trail.back()), 2, c, cv::FILLED, cv::LINE_AA);
  }

  // Legend: track age colour bar and the LiDAR dot.
  const int lx = 10, ly = H - 14;
  for (int i = 0; i <= 100; ++i)
    cv::line(panel, {lx + i, ly - 8}, {lx + i, ly}, ageColour(2 + i * (kMaxAgeColour - 2) / 100));
  cv::rectangle(panel, {lx - 1, ly - 9}, {lx + 101, ly + 1}, cv::Scalar(0, 0, 0));
  putText(panel,
          fmt::format("track age 2..{}+ frames ({}{})", kMaxAgeColour, order.size(),
                      order.size() < ages_.size() ? fmt::format(" of {} shown", ages_.size()) : ""),
          {lx + 108, ly}, 0.42);
  if (scan || setup_.has_lidar) {
    cv::circle(panel, {lx + 4, ly - 22}, 3, kLidarColour, cv::FILLED, cv::LINE_AA);
    putText(panel, fmt::format("LiDAR ({} points in view)", lidar_points), {lx + 14, ly - 18},
            0.42);
  }
  return panel;
}

cv::Mat Viewer::renderTopView(int S) const {
  cv::Mat panel(S, S, CV_8UC3, cv::Scalar(34, 34, 34));
  Trajectory est_as_traj;
  for (const auto& p : positions_W_) {
    StampedPose sp;
    sp.T_W_B.translation() = p;
    est_as_traj.push_back(sp);
  }
  const TopView view = view_ ? *view_ : chooseTopView(est_as_traj);
  std::vector<Vec2> gt, est;
  for (const auto& p : groundtruth_) gt.push_back(view.project(p.T_W_B.translation()));
  for (const auto& p : positions_W_) est.push_back(view.project(p));

  Vec2 lo(-5, -5), hi(5, 5);
  bool any = false;
  for (const auto* pts : {&gt, &est})
    for (const auto& p : *pts) {
      lo = any ? lo.cwiseMin(p) : p;
      hi = any ? hi.cwiseMax(p) : p;
      any = true;
    }
  const double margin = 36;
  const double span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 4.0});
  const double scale = (S - 2 * margin) / span;  // px per metre
  const Vec2 centre = 0.5 * (lo + hi);
  auto toPx = [&](const Vec2& p) {
    return toPoint(
        Vec2(0.5 * S + (p.x() - centre.x()) * scale, 0.5 * S + 8 - (p.y() - centre.y()) * scale));
  };

  // Grid with round spacing.
  const double half = 0.5 * S / scale;
  const auto ticks_a = niceTicks(centre.x() - half, centre.x() + half, 6);
  const auto ticks_b = niceTicks(centre.y() - half, centre.y() + half, 6);
  const double step = ticks_a.size() > 1 ? ticks_a[1] - ticks_a[0] : 1.0;
  for (const double a : ticks_a) {
    const int u = toPx({a, 0}).x;
    cv::line(panel, {u, 0}, {u, S}, cv::Scalar(56, 56, 56));
  }
  for (const double b : ticks_b) {
    const int v = toPx({0, b}).y;
    cv::line(panel, {0, v}, {S, v}, cv::Scalar(56, 56, 56));
  }

  auto polyline = [&](const std::vector<Vec2>& pts, const cv::Scalar& c, int thickness) {
    std::vector<cv::Point> px;
    px.reserve(pts.size());
    for (const auto& p : pts) px.push_back(toPx(p));
    if (px.size() >= 2) cv::polylines(panel, px, false, c, thickness, cv::LINE_AA);
  };
  polyline(gt, kTruthColour, 5);  // wide, so that it shows around an accurate estimate
  polyline(est, kEstimateColour, 2);
  if (!gt.empty()) cv::circle(panel, toPx(gt.front()), 4, kTruthColour, cv::FILLED, cv::LINE_AA);

  // Current pose: a dot and its heading (body x forward; camera-frame worlds: body z forward).
  if (last_ && !est.empty()) {
    const SE3 T = T_Wgt_W_.value_or(SE3::Identity()) * last_->T_W_B;
    const Vec3 fwd_B = view.up.y() < -0.5 ? Vec3::UnitZ() : Vec3::UnitX();
    Vec2 dir = view.project(T.linear() * fwd_B);
    const cv::Point p = toPx(est.back());
    if (dir.norm() > 1e-6) {
      dir.normalize();
      const cv::Point tip =
          p + cv::Point(static_cast<int>(22 * dir.x()), static_cast<int>(-22 * dir.y()));
      cv::arrowedLine(panel, p, tip, cv::Scalar(255, 255, 255), 2, cv::LINE_AA, 0, 0.35);
    }
    cv::circle(panel, p, 5, kEstimateColour, cv::FILLED, cv::LINE_AA);
    cv::circle(panel, p, 5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }

  // Title, scale bar and legend.
  putText(panel, fmt::format("top view ({}, {})", view.a_name, view.b_name), {10, 20}, 0.5);
  const int bar_px = static_cast<int>(std::lround(step * scale));
  cv::line(panel, {12, S - 14}, {12 + bar_px, S - 14}, kTextColour, 2);
  cv::line(panel, {12, S - 19}, {12, S - 9}, kTextColour, 2);
  cv::line(panel, {12 + bar_px, S - 19}, {12 + bar_px, S - 9}, kTextColour, 2);
  putText(panel, fmt::format("{:g} m", step), {18 + bar_px, S - 10}, 0.45);
  int ly = 20;
  cv::line(panel, {S - 150, ly - 4}, {S - 126, ly - 4}, kEstimateColour, 2, cv::LINE_AA);
  putText(panel, "estimate", {S - 120, ly}, 0.45);
  if (!gt.empty()) {
    ly += 18;
    cv::line(panel, {S - 150, ly - 4}, {S - 126, ly - 4}, kTruthColour, 5, cv::LINE_AA);
    putText(panel, T_Wgt_W_ ? "ground truth" : "ground truth (unaligned)", {S - 120, ly}, 0.45);
  }
  return panel;
}

cv::Mat Viewer::renderStatus(int width) const {
  cv::Mat bar(kStatusHeightPx, width, CV_8UC3, cv::Scalar(48, 48, 48));
  std::string text = fmt::format("ovo {}   frame {}", estimator_name_, frames_);
  if (last_) text += fmt::format("   t {:.2f} s", toSeconds(last_->t_ns));
  text += fmt::format("   tracks {}", ages_.size());
  if (info_.frames_dropped >= 0) text += fmt::format("   dropped {}", info_.frames_dropped);
  if (info_.latency_ms >= 0) text += fmt::format("   latency {:.0f} ms", info_.latency_ms);
  if (last_) text += fmt::format("   {:.0f}+{:.0f} ms", last_->frontend_ms, last_->estimator_ms);
  putText(bar, text, {10, 20}, 0.5);
  if (last_) {
    const bool ok = last_->tracked;
    const std::string state =
        ok ? (last_->is_keyframe ? "TRACKING  KF" : "TRACKING") : "LOST " + last_->status;
    int baseline = 0;
    const cv::Size sz = cv::getTextSize(state, cv::FONT_HERSHEY_SIMPLEX, 0.5, 2, &baseline);
    putText(bar, state, {width - sz.width - 12, 20}, 0.5,
            ok ? cv::Scalar(110, 220, 110) : cv::Scalar(80, 80, 255), 2);
  }
  return bar;
}

cv::Mat Viewer::renderCanvas() const {
  std::lock_guard lock(mutex_);
  const cv::Mat image = renderImagePanel();
  const cv::Mat top = renderTopView(options_.panel_height_px);
  const int W = image.cols + top.cols;
  cv::Mat canvas(kStatusHeightPx + options_.panel_height_px, W, CV_8UC3, cv::Scalar(0, 0, 0));
  renderStatus(W).copyTo(canvas(cv::Rect(0, 0, W, kStatusHeightPx)));
  image.copyTo(canvas(cv::Rect(0, kStatusHeightPx, image.cols, image.rows)));
  top.copyTo(canvas(cv::Rect(image.cols, kStatusHeightPx, top.cols, top.rows)));
  cv::line(canvas, {image.cols, kStatusHeightPx}, {image.cols, canvas.rows},
           cv::Scalar(90, 90, 90));
  return canvas;
}

void Viewer::saveSnapshot(const std::filesystem::path& png) const {
  const cv::Mat canvas = renderCanvas();
  bool ok = false;
  try {
    ok = cv::imwrite(png.string(), canvas);
  } catch (const cv::Exception& e) {
    fail("cannot write the viewer snapshot '{}': {}", png.string(), e.what());
  }
  if (!ok) fail("cannot write the viewer snapshot '{}'", png.string());
}

void Viewer::checkDisplay() {
  const char* x11 = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((x11 == nullptr || *x11 == '\0') && (wayland == nullptr || *wayland == '\0'))
    fail(
        "--viewer needs a display and DISPLAY is not set: run on a desktop, under xvfb-run, or "
        "use --viewer-snapshot FILE.png alone to save the viewer's canvas without a window");
}

void Viewer::spin(const std::function<bool()>& finished) {
  checkDisplay();
  if (!options_.show_window) {
    while (!finished()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return;
  }
  cv::namedWindow(options_.window_title, cv::WINDOW_AUTOSIZE);
  long shown = -1;
  for (;;) {
    const bool done = finished();
    long version;
    {
      std::lock_guard lock(mutex_);
      version = version_;
    }
    if (version != shown) {
      cv::imshow(options_.window_title, renderCanvas());
      shown = version;
    }
    const int key = cv::waitKey(30);
    if (done || key == 'q' || key == 27) break;
  }
  cv::destroyWindow(options_.window_title);
  cv::waitKey(1);
  while (!finished()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
}

void runWithViewer(Viewer& viewer, const std::function<void()>& work) {
  Viewer::checkDisplay();
  std::atomic<bool> done{false};
  std::exception_ptr error;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      error = std::current_exception();
    }
    done = true;
  });
  try {
    viewer.spin([&] { return done.load(); });
  } catch (...) {
    worker.join();
    throw;
  }
  worker.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace ovo::app
