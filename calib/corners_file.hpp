// Reading checkerboard corners from a text file instead of detecting them, so that the
// calibration can be checked apart from the detector (e.g. the corners another tool found).
#pragma once

#include <filesystem>
#include <vector>

#include "calib/board.hpp"

namespace ovo::calib {

/// Reads corners, one a line, '#' comments and blank lines ignored. Accepted line forms:
///   IMAGE INDEX U V X Y Z   (py-OCamCalib's decoded detections)
///   IMAGE U V X Y
///   U V X Y                 (one image; a blank line starts the next one)
/// U, V are pixels (column, row); X, Y are board coordinates in squares (multiplied by
/// square_m), Z must be 0. Images keep the file's order; each gets width x height. Throws
/// ovo::Error naming the file and line on anything else.
std::vector<BoardObservation> readCornersFile(const std::filesystem::path& file, double square_m,
                                              int width, int height);

}  // namespace ovo::calib
