// The simulator's checkerboard scene (`scene: checkerboard` in a scenario, e.g.
// configs/sim/checkerboard.yaml): a planar printed board seen by the scenario's camera from many
// random poses covering the image, rendered by ray casting with box-filtered pixels, plus the
// exact corner pixels and board poses as ground truth for camera calibration tests.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "camera/camera.hpp"
#include "common/types.hpp"

namespace ovo {
class Config;
}

namespace ovo::sim {

/// The board, the views and the image nuisances (keys under "board." and "nuisance.").
struct BoardSceneOptions {
  std::string calibration;  // camera.calibration: the camera file (ocam or yaml)
  std::uint64_t seed = 1;
  int cols = 9, rows = 6;       // inner corners
  double square_m = 0.06;       // square side (m)
  double margin_m = 0.04;       // white border around the squares (m)
  int views = 40;               // images
  double min_distance_m = 0.3;  // board centre's distance from the camera
  double max_distance_m = 0.8;
  double max_off_axis_deg = 110;  // board centre directions up to this angle off the axis
  double max_tilt_deg = 50;       // board normal away from the line of sight
  int supersample = 4;            // k x k jittered samples a pixel (box filter)
  double noise_sigma = 1.0;       // grey levels, Gaussian
  double black = 30, white = 220, background = 120;  // grey levels
};

/// Reads the board scene's keys (unknown keys are errors, as readScenario's); the camera file is
/// resolved like readScenario's camera.calibration.
BoardSceneOptions readBoardScene(const Config& config);
/// True when the scenario asks for the board scene (`scene: checkerboard`).
bool isBoardScene(const Config& config);

/// One view: the board's pose and its inner corners' true pixels (row-major, cols x rows).
struct BoardView {
  SE3 T_C_B = SE3::Identity();
  std::vector<Vec2> corners_px;
};

/// Board poses covering the camera's image: every corner and the board's outline (with margin)
/// inside the valid image, facing the camera. Deterministic for the seed.
std::vector<BoardView> boardViews(const camera::Camera& cam, const BoardSceneOptions& options);

/// View k rendered as 8-bit grey (black outside the camera's valid area).
cv::Mat renderBoardView(const camera::Camera& cam, const BoardSceneOptions& options,
                        const BoardView& view, int k);

/// The scene as YAML (written beside the images as sim/scenario.yaml).
std::string boardSceneYaml(const BoardSceneOptions& options);

}  // namespace ovo::sim
