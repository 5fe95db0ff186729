// A planar checkerboard target and the corners seen of it in one image: the input of every
// camera calibration in calib/ (from the detector, from a corner file, or from a test).
#pragma once

#include <string>
#include <vector>

#include "common/types.hpp"

namespace ovo::calib {

/// A checkerboard by its inner corners: `cols` x `rows` corners (the pattern size OpenCV's
/// detectors take), squares of `square_m` metres. Board frame: corner (i, j) (column i, row j) at
/// (i * square_m, j * square_m, 0).
struct BoardSpec {
  int cols = 0;
  int rows = 0;
  double square_m = 0.0;

  int cornerCount() const { return cols * rows; }
  /// Board-frame point of corner index k = j * cols + i.
  Vec3 point(int k) const;
};

/// Parses "8x6" (inner corners, columns x rows) with a square size; throws ovo::Error naming
/// `option` and what was expected.
BoardSpec parseBoardSpec(const std::string& text, double square_m,
                         const std::string& option = "--board");

/// The corners of one board in one image. Pixels are Vec2(u, v) = (column, row), origin at the
/// centre of the top-left pixel; points are in the board frame (metres, z = 0).
struct BoardObservation {
  std::string image;          // file name (for messages and the report)
  int width = 0, height = 0;  // image size in pixels
  std::vector<Vec2> corners_px;
  std::vector<Vec3> points_B;  // same length as corners_px
  std::size_t size() const { return corners_px.size(); }
};

/// An image left out of the calibration and why.
struct RejectedImage {
  std::string image;
  std::string reason;
};

}  // namespace ovo::calib
