// Checkerboard corners in one grey image: OpenCV's detectors (findChessboardCornersSB, then the
// classic findChessboardCorners with cornerSubPix) on the image itself, or, given a first
// calibration, on local perspective views of the fisheye image (for boards far off-axis, which
// the detectors miss in the raw image), their corners mapped back and refined in the raw image.
// Detections whose corner grid is not a plausible view of a board are refused with a reason.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "calib/board.hpp"
#include "camera/camera.hpp"

namespace ovo::calib {

struct DetectorOptions {
  int subpix_half_window_px = 11;  // largest cornerSubPix window (2 n + 1 pixels a side)
  int view_size_px = 640;          // perspective views: square, this many pixels a side
  double view_fov_deg = 100.0;     // and this field of view
  double max_turn_deg = 40.0;      // grid check: turn between consecutive corner steps
  double max_step_ratio = 3.0;     // grid check: ratio of consecutive steps along a line
};

/// A detection, or why there is none.
struct Detection {
  std::optional<BoardObservation> board;
  std::string method;  // "image (SB)", "image (classic)", "perspective view"
  std::string reason;  // when board is empty
};

/// Detects `spec` in `grey` (CV_8UC1). `name` labels the observation and the messages.
Detection detectBoard(const cv::Mat& grey, const BoardSpec& spec, const std::string& name,
                      const DetectorOptions& options = {});

/// Looks for the board in perspective views of `grey` through `model` (a first calibration),
/// centred on the optical axis and on two rings of directions around it.
Detection detectBoardInViews(const cv::Mat& grey, const BoardSpec& spec, const std::string& name,
                             const camera::Camera& model, const DetectorOptions& options = {});

/// Why a corner grid (cols x rows, row-major) is not a plausible board view; nullopt when it is.
std::optional<std::string> gridProblem(const std::vector<Vec2>& corners_px, const BoardSpec& spec,
                                       int width, int height, const DetectorOptions& options = {});

}  // namespace ovo::calib
