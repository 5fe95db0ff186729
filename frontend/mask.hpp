// The usable image area of a camera for feature detection: inside the image and the fisheye's
// valid circle / calibrated area (camera::isValid), shrunk by a border.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "camera/camera.hpp"

namespace ovo::frontend {

/// CV_8UC1 of the camera's size: 255 where every pixel within border_px (Chebyshev distance) is
/// valid and inside the image, else 0.
cv::Mat buildValidMask(const camera::Camera& cam, int border_px);

/// Unit bearings of every integer pixel (row-major, 3 floats each; zero where unproject fails).
std::vector<float> buildBearingTable(const camera::Camera& cam);

}  // namespace ovo::frontend
