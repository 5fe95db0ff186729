// The live viewer of `ovo run --viewer` and the live API: one OpenCV canvas with the camera image
// (tracks as trails coloured by age, LiDAR beam end points projected with T_C_L), a top view of
// the trajectory (ground truth, first-pose aligned, when known) and a status line. Frames are
// posted from any thread; the window runs on the main thread (OpenCV's Qt backend wants that);
// the canvas can be rendered and saved without any window or display.
#pragma once

#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "apps/svg_plot.hpp"
#include "estimator/estimator.hpp"

namespace ovo::app {

struct ViewerOptions {
  bool show_window = true;  // false: keep the canvas only (snapshots), no window
  std::string window_title = "ovo";
  int panel_height_px = 480;     // height of the image and top-view panels
  int max_image_width_px = 800;  // wide images (KITTI) are scaled to fit
  int trail_length = 12;         // past pixels drawn per track
};

/// What the status line shows besides the estimate (negative: not shown).
struct ViewerFrameInfo {
  int frames_dropped = -1;
  double latency_ms = -1.0;
};

/// A LiDAR beam end point in the image.
struct ProjectedBeam {
  Vec2 px;
  double range_m = 0.0;
};
/// The valid beams of `scan` that land inside the camera's valid area: p_C = T_C_L p_L, then
/// camera::project (points behind a pinhole camera or outside a fisheye's field are left out).
std::vector<ProjectedBeam> projectScan(const LidarScan& scan, const SE3& T_C_L,
                                       const camera::Camera& camera);

class Viewer {
 public:
  Viewer(const estimator::SensorSetup& setup, std::string estimator_name,
         ViewerOptions options = {});

  /// Thread-safe. Ground truth T_W_B for the top view (shown whole; the estimate is put onto it
  /// by its first pose).
  void setGroundTruth(const Trajectory& groundtruth);
  /// Thread-safe. The frame's image is drawn with the scan nearest to it in time (within 0.25 s).
  void addScan(const LidarScan& scan);
  /// Thread-safe. `grey` is kept by reference (cv::Mat sharing): do not modify it afterwards.
  void addFrame(const estimator::FrameEstimate& estimate, const cv::Mat& grey,
                const ViewerFrameInfo& info = {});

  /// Thread-safe. The whole canvas (BGR, 8 bit).
  cv::Mat renderCanvas() const;
  /// Writes renderCanvas() to a PNG; throws ovo::Error when it cannot.
  void saveSnapshot(const std::filesystem::path& png) const;

  /// Throws ovo::Error when no display is available (DISPLAY / WAYLAND_DISPLAY unset).
  static void checkDisplay();
  /// Shows the window and redraws it (~30 Hz) until finished() returns true or the user presses
  /// q / Esc. Call on the main thread. Throws ovo::Error without a display.
  void spin(const std::function<bool()>& finished);

 private:
  cv::Mat renderImagePanel() const;  // under mutex_
  cv::Mat renderTopView(int size_px) const;
  cv::Mat renderStatus(int width_px) const;

  estimator::SensorSetup setup_;
  SE3 T_C_L_;
  std::string estimator_name_;
  ViewerOptions options_;

  mutable std::mutex mutex_;
  long version_ = 0;  // bumped by every update
  Trajectory groundtruth_;
  std::optional<TopView> view_;
  std::optional<SE3> T_Wgt_W_;  // estimate world -> ground-truth world (first-pose alignment)
  std::deque<LidarScan> scans_;
  cv::Mat grey_;
  std::optional<estimator::FrameEstimate> last_;
  ViewerFrameInfo info_;
  int frames_ = 0;
  std::vector<Vec3> positions_W_;  // estimate, in the ground-truth world when aligned
  std::map<std::uint64_t, std::vector<Vec2>> trails_;
  std::map<std::uint64_t, int> ages_;
};

/// Runs `work` on a worker thread while `viewer` spins on the calling (main) thread; returns
/// when both are done and rethrows what `work` threw. Throws ovo::Error without a display
/// before starting anything.
void runWithViewer(Viewer& viewer, const std::function<void()>& work);

}  // namespace ovo::app
